// OpenCV's YAML calibration files (`%YAML:1.0`, `!!opencv-matrix` with rows/cols/dt/data, as
// cv::FileStorage writes them) read with yaml-cpp only: OpenCV 4.6's own YAML reader loops
// forever or calls std::terminate on some malformed files (fuzz_intrinsics), so it never sees
// untrusted YAML text. Private to CameraModel::load.
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace ips::detail {

/// The numbers of an OpenCV calibration file, checked as far as the file's own format goes
/// (shapes, dt, finite numbers, integer sizes); the camera model's rules are the caller's.
struct OpenCvIntrinsics {
  std::string model;     // the `model` key (fisheye/pinhole), empty if absent
  bool fisheye = false;  // the calibration sample's `fisheye_model` flag, nonzero
  int width = 0, height = 0;
  std::vector<double> K, D;
  std::string k_key, d_key;  // the keys as spelled in the file (camera_matrix, mtx, ...)
};

/// Parses OpenCV YAML text: an optional leading `%YAML:1.x` line (yaml-cpp does not know that
/// spelling of the directive), then exactly one YAML mapping. Throws ips::InputError naming
/// `where` and the line.
YAML::Node parse_opencv_yaml(const std::string& where, const std::string& text);

/// Reads the calibration keys from a parsed mapping (OpenCV's key spellings). Throws
/// ips::InputError naming `where`, the line and the key.
OpenCvIntrinsics read_opencv_intrinsics(const std::string& where, const YAML::Node& root);

}  // namespace ips::detail
