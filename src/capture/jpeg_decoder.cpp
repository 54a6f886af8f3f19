#include "ips/capture/jpeg_decoder.h"

#include <stdexcept>

#include <turbojpeg.h>

namespace ips {

JpegDecoder::JpegDecoder() : handle_(tjInitDecompress()) {
  if (handle_ == nullptr) throw std::runtime_error("libjpeg-turbo: tjInitDecompress failed");
}

JpegDecoder::~JpegDecoder() { tjDestroy(handle_); }

bool JpegDecoder::read_size(std::span<const std::uint8_t> jpeg, int& width, int& height) {
  int subsampling = 0;
  int colorspace = 0;
  if (jpeg.size() < 4 || tjDecompressHeader3(handle_, jpeg.data(), static_cast<unsigned long>(jpeg.size()), &width,
                                             &height, &subsampling, &colorspace) != 0) {
    error_ = jpeg.size() < 4 ? "too short to be a JPEG" : tjGetErrorStr2(handle_);
    return false;
  }
  return true;
}

bool JpegDecoder::decode_gray(std::span<const std::uint8_t> jpeg, cv::Mat& gray, int scale_denom) {
  if (scale_denom != 1 && scale_denom != 2 && scale_denom != 4 && scale_denom != 8) {
    throw std::invalid_argument("JpegDecoder: scale_denom must be 1, 2, 4 or 8");
  }
  int width = 0;
  int height = 0;
  if (!read_size(jpeg, width, height)) return false;
  const tjscalingfactor factor{1, scale_denom};
  const int out_w = TJSCALED(width, factor);
  const int out_h = TJSCALED(height, factor);
  gray.create(out_h, out_w, CV_8UC1);  // no-op when the size is unchanged
  const int flags = TJFLAG_FASTDCT | TJFLAG_STOPONWARNING;
  if (tjDecompress2(handle_, jpeg.data(), static_cast<unsigned long>(jpeg.size()), gray.data, out_w,
                    static_cast<int>(gray.step), out_h, TJPF_GRAY, flags) != 0) {
    error_ = tjGetErrorStr2(handle_);
    return false;
  }
  return true;
}

}  // namespace ips
