// A square marker's full pose from its four corners: both IPPE solutions (OpenCV's
// SOLVEPNP_IPPE_SQUARE through solvePnPGeneric, on normalised coordinates), and a camera's
// pose recovered from its mapper's world rays.
#include <algorithm>
#include <cmath>

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "ips/body/body_estimate.h"

namespace ips {

std::vector<MarkerPoseSolution> planar_marker_poses(const std::array<Point2, 4>& corners_norm, double edge) {
  std::vector<MarkerPoseSolution> out;
  const double h = edge / 2.0;
  // The object points SOLVEPNP_IPPE_SQUARE requires, in ArUco corner order.
  const std::vector<cv::Point3d> obj{{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  std::vector<cv::Point2d> img;
  for (const auto& c : corners_norm) {
    if (!std::isfinite(c.x) || !std::isfinite(c.y)) return out;
    img.emplace_back(c.x, c.y);
  }
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat errors;
  try {
    cv::solvePnPGeneric(obj, img, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE_SQUARE,
                        cv::noArray(), cv::noArray(), errors);
  } catch (const cv::Exception&) {
    return out;  // degenerate corners (a sliver seen edge-on)
  }
  for (std::size_t i = 0; i < rvecs.size(); ++i) {
    MarkerPoseSolution s;
    cv::Mat R;
    cv::Rodrigues(rvecs[i], R);
    cv::cv2eigen(R, s.R);
    s.t = {tvecs[i].at<double>(0), tvecs[i].at<double>(1), tvecs[i].at<double>(2)};
    s.error = errors.empty() ? 0.0 : errors.at<double>(static_cast<int>(i));
    if (!(s.t.z() > 0) || !s.R.allFinite()) continue;
    out.push_back(s);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.error < b.error; });
  return out;
}

bool camera_pose_of(const Mapper& mapper, CameraPose& pose) {
  // The rays of the optical axis and of two points a little off it: the camera's axes in the
  // world. (A plane model's small radial correction scales the offsets by 1 + O(1e-6) only.)
  constexpr double kStep = 1e-3;
  Eigen::Vector3d o0, o1, o2, d0, d1, d2;
  if (!mapper.world_ray({0, 0, 1}, o0, d0) || !mapper.world_ray({kStep, 0, 1}, o1, d1) ||
      !mapper.world_ray({0, kStep, 1}, o2, d2))
    return false;
  const Eigen::Vector3d z = d0.normalized();
  Eigen::Vector3d x = d1 / d1.dot(z) - z;
  x = (x - x.dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  pose.R_wc.col(0) = x;
  pose.R_wc.col(1) = y;
  pose.R_wc.col(2) = z;
  pose.centre = o0;
  return pose.R_wc.allFinite() && (d2 / d2.dot(z) - z).dot(y) > 0;  // a right-handed camera frame
}

}  // namespace ips
