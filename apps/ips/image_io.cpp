#include "image_io.h"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/core/error.h"

namespace ips::cli {

cv::Mat read_gray_image(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open image");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.empty()) throw InputError(path.string() + ": empty file, not an image");
  cv::Mat gray;
  if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF) {
    JpegDecoder decoder;
    if (!decoder.decode_gray(bytes, gray)) {
      throw InputError(path.string() + ": broken JPEG: " + decoder.error());
    }
    return gray;
  }
  try {
    gray = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw InputError(path.string() + ": cannot decode image: " + e.msg);
  }
  if (gray.empty()) throw InputError(path.string() + ": not a readable image (JPEG, PNG, BMP, TIFF, ...)");
  return gray;
}

void write_file_atomically(const std::filesystem::path& path, const std::string& bytes) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(tmp.string() + ": cannot write");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) throw std::runtime_error(tmp.string() + ": write failed");
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace ips::cli
