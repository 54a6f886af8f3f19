// Reading one image file for the toolbox (JPEG through turbojpeg, anything else through
// OpenCV), and writing output files atomically.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace ips::cli {

/// Loads an image file as 8-bit greyscale. Throws ips::InputError naming the file when it
/// cannot be read or decoded.
cv::Mat read_gray_image(const std::filesystem::path& path);

/// Writes `bytes` to `path` through a temporary file and a rename, so that a reader never
/// sees a partial file. Throws std::runtime_error on I/O failure.
void write_file_atomically(const std::filesystem::path& path, const std::string& bytes);

}  // namespace ips::cli
