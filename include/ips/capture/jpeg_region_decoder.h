// Partial MJPEG decode for tracking: only the image rows and columns that regions of
// interest need are decoded to pixels, with libjpeg-turbo's jpeg_crop_scanline (columns,
// widened to whole MCUs) and jpeg_skip_scanlines (rows).
//
// Rows above a region cost what remains of a decode: a JPEG's entropy-coded (Huffman) data is
// one bit stream, so skipped rows are still Huffman-decoded (not IDCT'd) unless the frame has
// restart markers. Where it has (jpeg_restart.h), the MCU rows around the regions are cut out
// at the nearest restart markers and only they are decoded: nothing above them is read. Rows
// below the lowest region are never decoded either way.
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

  /// Frames whose rows were cut out at restart markers (nothing above the regions decoded),
  /// frames decoded by skipping rows, and frames whose restart markers were not where their
  /// headers put them (decoded by skipping instead).
  std::uint64_t entered_at_restarts() const { return entered_at_restarts_; }
  std::uint64_t skipped_by_huffman() const { return skipped_by_huffman_; }
  std::uint64_t restart_fallbacks() const { return restart_fallbacks_; }
  /// Why the last of those fallbacks happened (where the markers were not), for the log.
  const std::string& restart_problem() const;

 private:
  bool plan_restart_cut(std::span<const std::uint8_t> jpeg, int width, int height);
  bool decode_cut(cv::Mat& gray, int x0, int x1);

  struct Impl;
  Impl* impl_ = nullptr;
  std::string error_;
  std::uint64_t entered_at_restarts_ = 0, skipped_by_huffman_ = 0, restart_fallbacks_ = 0;
};

}  // namespace ips
