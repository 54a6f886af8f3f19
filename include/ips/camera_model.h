// Intrinsic camera model (OpenCV fisheye or pinhole): undistort and project.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/observation.h"

namespace ips {

class CameraModel {
 public:
  enum class Kind { kFisheye, kPinhole };

  CameraModel() = default;
  CameraModel(Kind kind, cv::Size size, cv::Matx33d K, std::vector<double> D);

  /// Reads the ipsd YAML form (model, image_width, image_height, K, D) or an OpenCV
  /// FileStorage calibration file. Throws ips::InputError naming the file and the key.
  static CameraModel load(const std::filesystem::path& path);

  /// Pixels -> normalised image coordinates (u, v) = (X/Z, Y/Z) of the viewing ray.
  Point2 undistort(Point2 px) const;
  void undistort(std::span<const Point2> px, std::span<Point2> norm) const;

  /// Normalised coordinates -> pixels (the inverse of undistort).
  Point2 project(Point2 norm) const;

  Kind kind() const { return kind_; }
  cv::Size size() const { return size_; }
  const cv::Matx33d& K() const { return K_; }
  const std::vector<double>& D() const { return D_; }

 private:
  Kind kind_ = Kind::kFisheye;
  cv::Size size_;
  cv::Matx33d K_ = cv::Matx33d::eye();
  std::vector<double> D_;
};

}  // namespace ips
