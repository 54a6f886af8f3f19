// MJPEG frame -> 8-bit greyscale, with libjpeg-turbo. Detection needs only luminance,
// so chroma is never converted; optional DCT-domain downscaling (1/2, 1/4, 1/8) makes
// decoding cheaper still when detection runs at reduced scale.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include <opencv2/core.hpp>

namespace ips {

class JpegDecoder {
 public:
  JpegDecoder();
  ~JpegDecoder();
  JpegDecoder(const JpegDecoder&) = delete;
  JpegDecoder& operator=(const JpegDecoder&) = delete;

  /// Decodes `jpeg` into `gray` (CV_8UC1, reallocated only when the size changes, so a
  /// stream of same-sized frames decodes without allocation). `scale_denom` is 1, 2, 4
  /// or 8: the output is ceil(width / scale_denom) x ceil(height / scale_denom).
  /// Returns false for a corrupt or truncated image (libjpeg warnings count as corrupt:
  /// a half-decoded frame must not reach the detector); error() then says why.
  bool decode_gray(std::span<const std::uint8_t> jpeg, cv::Mat& gray, int scale_denom = 1);

  /// Reads only the header. Returns false if it is not a JPEG.
  bool read_size(std::span<const std::uint8_t> jpeg, int& width, int& height);

  const std::string& error() const { return error_; }

 private:
  void* handle_ = nullptr;  // tjhandle
  std::string error_;
};

}  // namespace ips
