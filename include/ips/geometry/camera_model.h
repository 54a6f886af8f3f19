// Intrinsic camera model (OpenCV fisheye or pinhole): undistort and project.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/core/observation.h"

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
  /// Exact inverse of project() (Newton to machine precision). A pixel the model cannot
  /// map to a ray (beyond where a fitted fisheye polynomial turns back, typically the
  /// extreme image corners) gives NaN coordinates.
  Point2 undistort(Point2 px) const;
  void undistort(std::span<const Point2> px, std::span<Point2> norm) const;

  /// True if undistort(px) gives a ray (see undistort).
  bool has_ray(Point2 px) const {
    const Point2 n = undistort(px);
    return n.x == n.x && n.y == n.y;
  }

  /// Largest angle from the optical axis the model covers, radians (fisheye; pi/2 for pinhole).
  double max_theta() const { return max_theta_; }

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
  double max_theta_ = 1.5707963267948966;
  double max_theta_d_ = 1e300;
};

}  // namespace ips
