// ArUco marker detection tuned for 1080p overhead fisheye frames.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/observation.h"

namespace ips {

struct DetectorOptions {
  std::string dictionary = "DICT_4X4_100";  ///< OpenCV predefined dictionary name
  // The perception work adds its documented tunables here (scale, threshold passes, ...).
};

class Detector {
 public:
  /// Throws ips::InputError for an unknown dictionary name.
  explicit Detector(const DetectorOptions& options = {});
  ~Detector();
  Detector(Detector&&) noexcept;
  Detector& operator=(Detector&&) noexcept;

  /// Finds markers in an 8-bit greyscale image; corners refined to sub-pixel accuracy.
  std::vector<MarkerDetection> detect(const cv::Mat& gray);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ips
