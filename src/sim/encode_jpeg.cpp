// JPEG compression of rendered frames: as a camera's MJPEG (YCbCr 4:2:0) or as a greyscale JPEG,
// optionally with restart markers.
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include <turbojpeg.h>

#include <opencv2/imgproc.hpp>

#include "ips/capture/libjpeg_errors.h"
#include "ips/core/error.h"
#include "ips/sim/renderer.h"

namespace ips::sim {
namespace {

// TurboJPEG 2 (Debian 12) has no restart setting: frames with restart markers go through the
// libjpeg API with the same choices as tjCompress2 (standard tables scaled by quality, 4:2:0,
// the fast integer DCT).
std::vector<std::uint8_t> encode_with_restarts(const cv::Mat& gray, int quality, bool colour, int restart_rows) {
  // Colour: a grey BGR image in, YCbCr 4:2:0 out (libjpeg's defaults for it), flat chroma, as
  // tjCompress2 makes it.
  cv::Mat src = gray;
  if (colour) cv::cvtColor(gray, src, cv::COLOR_GRAY2BGR);
  jpeg_compress_struct c{};
  LibjpegErrors err{};
  c.err = install_libjpeg_errors(err, false);
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  if (setjmp(err.jump) != 0) {
    jpeg_destroy_compress(&c);
    std::free(buf);
    throw std::runtime_error(std::string("libjpeg: ") + err.message);
  }
  jpeg_create_compress(&c);
  jpeg_mem_dest(&c, &buf, &size);
  c.image_width = static_cast<JDIMENSION>(src.cols);
  c.image_height = static_cast<JDIMENSION>(src.rows);
  c.input_components = colour ? 3 : 1;
  c.in_color_space = colour ? JCS_EXT_BGR : JCS_GRAYSCALE;
  jpeg_set_defaults(&c);
  jpeg_set_quality(&c, quality, TRUE);
  c.dct_method = JDCT_IFAST;
  c.restart_in_rows = restart_rows;
  jpeg_start_compress(&c, TRUE);
  while (c.next_scanline < c.image_height) {
    auto* row = src.ptr<JSAMPLE>(static_cast<int>(c.next_scanline));
    jpeg_write_scanlines(&c, &row, 1);
  }
  jpeg_finish_compress(&c);
  jpeg_destroy_compress(&c);
  std::vector<std::uint8_t> out(buf, buf + size);
  std::free(buf);
  return out;
}

}  // namespace

std::vector<std::uint8_t> encode_jpeg(const cv::Mat& gray, int quality, bool colour, int restart_rows) {
  if (quality < 1 || quality > 100) throw InputError("JPEG quality must be 1..100, got " + std::to_string(quality));
  if (restart_rows < 0 || restart_rows > 255)
    throw InputError("JPEG restart interval must be 0..255 MCU rows, got " + std::to_string(restart_rows));
  if (gray.type() != CV_8UC1 || gray.empty()) throw std::invalid_argument("encode_jpeg: expected CV_8UC1");
  if (restart_rows > 0) return encode_with_restarts(gray, quality, colour, restart_rows);
  // One compressor per thread: tjInitCompress allocates, frames come at video rate.
  struct Handle {
    tjhandle h = tjInitCompress();
    ~Handle() { tjDestroy(h); }
  };
  thread_local Handle handle;
  if (handle.h == nullptr) throw std::runtime_error("libjpeg-turbo: tjInitCompress failed");
  cv::Mat src = gray;
  int format = TJPF_GRAY;
  int subsampling = TJSAMP_GRAY;
  if (colour) {
    cv::cvtColor(gray, src, cv::COLOR_GRAY2BGR);
    format = TJPF_BGR;
    subsampling = TJSAMP_420;
  }
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  if (tjCompress2(handle.h, src.data, src.cols, static_cast<int>(src.step), src.rows, format, &buf, &size, subsampling,
                  quality, TJFLAG_FASTDCT) != 0) {
    const std::string err = tjGetErrorStr2(handle.h);
    tjFree(buf);
    throw std::runtime_error("libjpeg-turbo: " + err);
  }
  std::vector<std::uint8_t> out(buf, buf + size);
  tjFree(buf);
  return out;
}

}  // namespace ips::sim
