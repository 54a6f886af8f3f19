// Partial MJPEG decode for tracking: only the image rows and columns that regions of
// interest need are decoded to pixels, with libjpeg-turbo's jpeg_crop_scanline (columns,
// widened to whole MCUs) and jpeg_skip_scanlines (rows). What remains is the entropy
// (Huffman) decoding of the rows above the lowest ROI: a baseline JPEG without restart
// markers cannot be entered mid-stream, so skipped rows are still Huffman-decoded (not
// IDCT'd); rows below the lowest ROI are not decoded at all. (With restart markers every
// few MCU rows a decoder could seek to the first ROI row instead.)
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace ips {

class JpegRegionDecoder {
 public:
  JpegRegionDecoder();
  ~JpegRegionDecoder();
  JpegRegionDecoder(const JpegRegionDecoder&) = delete;
  JpegRegionDecoder& operator=(const JpegRegionDecoder&) = delete;

  /// Decodes the luma of `jpeg` into `gray` (CV_8UC1 of the full image size, reallocated only
  /// when the size changes) inside `rois` only: the pixels of every ROI equal a full decode's
  /// (same IDCT as JpegDecoder: the fast integer one); other pixels keep whatever they held.
  /// An empty `rois` decodes the whole image. Returns false for a corrupt JPEG (error() says
  /// why).
  bool decode(std::span<const std::uint8_t> jpeg, cv::Mat& gray, const std::vector<cv::Rect>& rois);

  /// Reads only the header: the image size. Returns false if it is not a JPEG (error()).
  bool read_size(std::span<const std::uint8_t> jpeg, cv::Size& size);

  const std::string& error() const { return error_; }

 private:
  struct Impl;
  Impl* impl_ = nullptr;
  std::string error_;
};

}  // namespace ips
