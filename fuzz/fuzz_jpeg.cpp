// JPEG frames through the capture decode path: a USB camera's MJPEG buffer (or a file source's
// image) goes to JpegDecoder::decode_gray at the configured decode_scale, and with tracking to
// JpegRegionDecoder::decode for the regions around predicted markers (with restart markers in the
// stream, by cutting the regions' rows out of it: capture/jpeg_restart.h). Any bytes decode or are
// refused (false + error()); beyond "no fault", the region decoder's pixels inside its regions
// equal the full decode's (its documented contract), and read_size agrees with the decode.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/capture/jpeg_region_decoder.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ips::JpegDecoder decoder;
  static ips::JpegRegionDecoder region_decoder;
  const std::span<const std::uint8_t> jpeg(data, size);
  int width = 0, height = 0;
  const bool header = decoder.read_size(jpeg, width, height);
  cv::Mat full;
  const bool decoded = decoder.decode_gray(jpeg, full, 1);
  if (decoded && (!header || full.cols != width || full.rows != height)) std::abort();
  // The configured decode scales, picked by the input's length so every input tries one.
  const int scale = 2 << (size % 3);  // 2, 4 or 8
  cv::Mat small;
  if (decoder.decode_gray(jpeg, small, scale) && decoded &&
      (small.cols != (width + scale - 1) / scale || small.rows != (height + scale - 1) / scale))
    std::abort();
  if (!header || width <= 0 || height <= 0) return 0;
  // Two regions as the tracker asks for them: one near the top left, one in the lower half.
  const cv::Rect image(0, 0, width, height);
  const std::vector<cv::Rect> rois = {cv::Rect(width / 8, height / 8, width / 4 + 1, height / 5 + 1) & image,
                                      cv::Rect(width / 2, height * 3 / 5, width / 3 + 1, height / 4 + 1) & image};
  // And the lower one alone: with restart markers, its rows are cut out of the stream and
  // nothing above them is decoded.
  const std::vector<cv::Rect> lower = {rois[1]};
  for (const auto* set : {&rois, &lower}) {
    cv::Mat part;
    if (region_decoder.decode(jpeg, part, *set) && decoded) {
      if (part.size() != full.size()) std::abort();
      for (const cv::Rect& r : *set)
        if (r.area() > 0 && cv::norm(part(r), full(r), cv::NORM_INF) != 0) std::abort();
    }
  }
  return 0;
}
