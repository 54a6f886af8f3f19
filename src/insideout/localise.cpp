#include "ips/insideout/localise.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

namespace ips {
namespace {
// Named inside the anonymous namespace: unity builds put this file beside others whose own
// helpers (residual, cost, ...) would collide.
namespace ceiling_pose {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// Residual of a corner that does not project (behind the lens or outside its field): large
// enough to lose against any pose that explains the corner, finite so that sums stay ordered.
constexpr double kNoProjectionPx = 1e4;

struct Corner {
  Eigen::Vector3d world;
  Point2 px;
  int marker = 0;  // index into the markers used
};

struct CameraPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // camera axes in the world
  Eigen::Vector3d c = Eigen::Vector3d::Zero();      // lens centre in the world
};

// The floor is level: the robot's z axis is near the world's. Two residuals (its x and y
// components, in units of tilt_sigma, scaled to pixels so that one sigma of either costs what
// one sigma of corner noise does); none when tilt_sigma is 0.
struct TiltPrior {
  Eigen::Matrix3d camera_axes_in_robot = Eigen::Matrix3d::Identity();
  double weight = 0.0;  // pixel_sigma / tilt_sigma
  Eigen::Vector2d residual(const CameraPose& p) const {
    const Eigen::Vector3d up = p.R * camera_axes_in_robot.transpose().col(2);  // robot z in the world
    return weight * up.head<2>();
  }
};

// World-frame rotation increment first, then the lens centre's shift.
CameraPose perturbed(const CameraPose& p, const Vec6& d) {
  CameraPose q;
  const Eigen::Vector3d w = d.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d dR =
      angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  q.R = dR * p.R;
  q.c = p.c + d.tail<3>();
  return q;
}

// Pixel residual (projection - observation) of one corner; false when it does not project.
bool residual(const CameraPose& p, const Corner& k, const CameraModel& camera, Eigen::Vector2d& r) {
  const Eigen::Vector3d pc = p.R.transpose() * (k.world - p.c);
  if (!(pc.z() > 1e-9) || std::atan2(std::hypot(pc.x(), pc.y()), pc.z()) >= camera.max_theta()) {
    r = Eigen::Vector2d::Constant(kNoProjectionPx);
    return false;
  }
  const Point2 px = camera.project({pc.x() / pc.z(), pc.y() / pc.z()});
  r = {px.x - k.px.x, px.y - k.px.y};
  return std::isfinite(r.x()) && std::isfinite(r.y());
}

double cost(const CameraPose& p, const std::vector<Corner>& corners, const CameraModel& camera,
            const TiltPrior& prior) {
  double s = prior.residual(p).squaredNorm();
  Eigen::Vector2d r;
  for (const auto& k : corners) {
    residual(p, k, camera, r);
    s += r.squaredNorm();
  }
  return s;
}

// Residuals and their Jacobian by central differences (the lens model has no analytic one
// here; 12 projections per corner is cheap beside detection).
// The last two rows are the tilt prior's.
void linearise(const CameraPose& p, const std::vector<Corner>& corners, const CameraModel& camera,
               const TiltPrior& prior, Eigen::VectorXd& r, Eigen::MatrixXd& J) {
  const auto n = static_cast<Eigen::Index>(corners.size());
  r.resize(2 * n + 2);
  J.resize(2 * n + 2, 6);
  Eigen::Vector2d e, ep, em;
  for (Eigen::Index i = 0; i < n; ++i) {
    residual(p, corners[static_cast<std::size_t>(i)], camera, e);
    r.segment<2>(2 * i) = e;
  }
  r.segment<2>(2 * n) = prior.residual(p);
  for (int j = 0; j < 6; ++j) {
    const double h = 1e-6;
    Vec6 d = Vec6::Zero();
    d[j] = h;
    const CameraPose plus = perturbed(p, d), minus = perturbed(p, -d);
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto& k = corners[static_cast<std::size_t>(i)];
      residual(plus, k, camera, ep);
      residual(minus, k, camera, em);
      J.block<2, 1>(2 * i, j) = (ep - em) / (2 * h);
    }
    J.block<2, 1>(2 * n, j) = (prior.residual(plus) - prior.residual(minus)) / (2 * h);
  }
}

// Levenberg-Marquardt on the pixel residuals; returns the final cost.
double refine(CameraPose& p, const std::vector<Corner>& corners, const CameraModel& camera, const TiltPrior& prior,
              int iterations) {
  double lambda = 1e-3;
  double current = cost(p, corners, camera, prior);
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  for (int it = 0; it < iterations; ++it) {
    linearise(p, corners, camera, prior, r, J);
    const Mat6 H = J.transpose() * J;
    const Vec6 g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Mat6 A = H;
      A.diagonal() += lambda * H.diagonal().cwiseMax(1e-9);
      const Vec6 d = A.ldlt().solve(-g);
      if (!d.allFinite()) break;
      const CameraPose q = perturbed(p, d);
      const double c = cost(q, corners, camera, prior);
      if (c < current) {
        const double gain = current - c;
        p = q;
        current = c;
        lambda = std::max(lambda / 3, 1e-9);
        improved = true;
        if (gain < 1e-12 * std::max(1.0, current) || d.norm() < 1e-10) return current;
      } else {
        lambda *= 8;
      }
    }
    if (!improved) break;
  }
  return current;
}

// IPPE's two camera poses from one marker; none if a corner has no ray.
std::vector<CameraPose> ippe_candidates(const CeilingMarker& m, const MarkerDetection& d, const CameraModel& camera) {
  std::vector<CameraPose> out;
  const Eigen::Matrix3d A = m.axes();  // marker axes in the world
  for (const MarkerInCamera& v : marker_in_camera(d, m.length, camera)) {
    CameraPose p;
    p.R = A * v.R.transpose();        // camera axes in the world
    p.c = m.centre - p.R * v.centre;  // the marker centre is at v.centre in the camera
    if (p.R.allFinite() && p.c.allFinite()) out.push_back(p);
  }
  return out;
}

std::vector<Corner> corners_of(const std::vector<const CeilingMarker*>& markers,
                               const std::vector<const MarkerDetection*>& dets) {
  std::vector<Corner> out;
  for (std::size_t m = 0; m < markers.size(); ++m) {
    const auto world = markers[m]->corners();
    for (int i = 0; i < 4; ++i) out.push_back({world[i], dets[m]->corners_px[i], static_cast<int>(m)});
  }
  return out;
}

// Per-marker RMS reprojection error, px.
std::vector<double> marker_rms(const CameraPose& p, const std::vector<Corner>& corners, std::size_t markers,
                               const CameraModel& camera) {
  std::vector<double> sum(markers, 0.0);
  Eigen::Vector2d r;
  for (const auto& k : corners) {
    residual(p, k, camera, r);
    sum[static_cast<std::size_t>(k.marker)] += r.squaredNorm();
  }
  for (auto& s : sum) s = std::sqrt(s / 4);
  return sum;
}

// The robot's x, y, z, yaw for a camera pose.
Eigen::Vector4d robot_state(const CameraPose& p, const CameraMount& mount, Eigen::Matrix3d* axes = nullptr) {
  const Eigen::Matrix3d R_wr = p.R * mount.camera_axes().transpose();
  if (axes != nullptr) *axes = R_wr;
  const Eigen::Vector3d origin = p.c - R_wr * mount.offset;
  return {origin.x(), origin.y(), origin.z(), std::atan2(R_wr(1, 0), R_wr(0, 0))};
}

}  // namespace ceiling_pose
}  // namespace

std::vector<MarkerInCamera> marker_in_camera(const MarkerDetection& d, double length, const CameraModel& camera) {
  std::vector<cv::Point2d> image;
  for (const auto& c : d.corners_px) {
    const Point2 n = camera.undistort(c);
    if (!std::isfinite(n.x) || !std::isfinite(n.y)) return {};
    image.emplace_back(n.x, n.y);
  }
  const double h = length / 2;
  // The marker frame as OpenCV's IPPE_SQUARE wants it: x right, y up as printed, z out of the face.
  const std::vector<cv::Point3d> object{{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::solvePnPGeneric(object, image, cv::Matx33d::eye(), cv::noArray(), rvecs, tvecs, false,
                        cv::SOLVEPNP_IPPE_SQUARE);
  } catch (const cv::Exception&) {
    return {};  // degenerate corners (a sliver of a marker)
  }
  std::vector<MarkerInCamera> out;
  for (std::size_t i = 0; i < rvecs.size(); ++i) {
    cv::Matx33d Rcv;
    cv::Rodrigues(rvecs[i], Rcv);
    MarkerInCamera v;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) v.R(r, c) = Rcv(r, c);
    const cv::Vec3d t(tvecs[i]);
    v.centre = {t[0], t[1], t[2]};
    if (v.R.allFinite() && v.centre.allFinite()) out.push_back(v);
  }
  return out;
}

Eigen::Matrix3d CameraMount::camera_axes() const {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Localisation localise(std::span<const MarkerDetection> detections, const CameraModel& camera, const CeilingMap& map,
                      const CameraMount& mount, const LocaliseOptions& options) {
  using namespace ceiling_pose;
  Localisation out;
  std::vector<const CeilingMarker*> markers;
  std::vector<const MarkerDetection*> dets;
  for (const auto& d : detections) {
    const CeilingMarker* m = map.find(d.id);
    if (m == nullptr) {
      out.unknown.push_back(d.id);
      continue;
    }
    if (std::find(out.used.begin(), out.used.end(), d.id) != out.used.end()) continue;  // a duplicate read
    markers.push_back(m);
    dets.push_back(&d);
    out.used.push_back(d.id);
  }
  if (markers.empty()) {
    out.used.clear();
    out.why = detections.empty() ? "no marker in view" : "no marker of the map in view";
    return out;
  }

  // Seeds: IPPE on the markers nearest the image centre (least distorted, largest in view).
  std::vector<std::size_t> order(markers.size());
  std::vector<double> off_centre(markers.size());
  for (std::size_t m = 0; m < markers.size(); ++m) {
    order[m] = m;
    Point2 mean{0, 0};
    for (const auto& c : dets[m]->corners_px) mean = {mean.x + c.x / 4, mean.y + c.y / 4};
    const Point2 n = camera.undistort(mean);
    off_centre[m] = std::isfinite(n.x) ? std::hypot(n.x, n.y) : std::numeric_limits<double>::infinity();
  }
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return off_centre[a] < off_centre[b]; });
  std::vector<Corner> corners = corners_of(markers, dets);
  TiltPrior prior;
  prior.camera_axes_in_robot = mount.camera_axes();
  prior.weight = options.tilt_sigma > 0 ? options.pixel_sigma / options.tilt_sigma : 0.0;
  const Eigen::Vector3d mount_up = mount.camera_axes().col(2);  // the optical axis, robot frame
  CameraPose best;
  double best_cost = std::numeric_limits<double>::infinity(), best_tilt = 0;
  for (std::size_t k = 0; k < std::min<std::size_t>(3, order.size()); ++k) {
    for (const CameraPose& p : ippe_candidates(*markers[order[k]], *dets[order[k]], camera)) {
      const double c = cost(p, corners, camera, prior);
      // The robot stands on a floor: its z axis is near world z, so the optical axis is near
      // the mount's direction turned by the robot's heading. Its tilt separates IPPE's twins.
      const double tilt = std::acos(std::clamp(p.R(2, 2), -1.0, 1.0)) - std::acos(std::clamp(mount_up.z(), -1.0, 1.0));
      const bool much_better = c < 0.5 * best_cost;
      const bool alike = c < 2 * best_cost;
      if (much_better || (alike && std::abs(tilt) < std::abs(best_tilt))) {
        best = p;
        best_cost = c;
        best_tilt = tilt;
      }
    }
  }
  if (!std::isfinite(best_cost)) {
    out.why = "no pose from the markers' corners (degenerate or outside the lens model)";
    out.used.clear();
    return out;
  }

  refine(best, corners, camera, prior, options.max_iterations);
  // Drop the worst marker while it disagrees with the others.
  for (;;) {
    const auto rms = marker_rms(best, corners, markers.size(), camera);
    const auto worst = static_cast<std::size_t>(std::max_element(rms.begin(), rms.end()) - rms.begin());
    if (rms[worst] <= options.outlier_px) break;
    if (markers.size() == 1) {
      out.rejected.push_back(markers[0]->id);
      out.used.clear();
      char why[96];
      std::snprintf(why, sizeof why, "the only marker's corners fit no pose within %.1f px", options.outlier_px);
      out.why = why;
      return out;
    }
    out.rejected.push_back(markers[worst]->id);
    markers.erase(markers.begin() + static_cast<std::ptrdiff_t>(worst));
    dets.erase(dets.begin() + static_cast<std::ptrdiff_t>(worst));
    corners = corners_of(markers, dets);
    refine(best, corners, camera, prior, options.max_iterations);
  }
  out.used.clear();
  for (const auto* m : markers) out.used.push_back(m->id);

  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  linearise(best, corners, camera, prior, r, J);
  out.rms_px = std::sqrt(r.head(r.size() - 2).squaredNorm() / static_cast<double>(corners.size()));
  const Mat6 H = J.transpose() * J;
  const Mat6 cov6 = options.pixel_sigma * options.pixel_sigma * H.ldlt().solve(Mat6::Identity());
  // Carry the camera pose's covariance to the robot's x, y, z, yaw (numerically).
  Eigen::Matrix<double, 4, 6> G;
  for (int j = 0; j < 6; ++j) {
    Vec6 d = Vec6::Zero();
    d[j] = 1e-6;
    Eigen::Vector4d diff = robot_state(perturbed(best, d), mount) - robot_state(perturbed(best, -d), mount);
    diff[3] = std::remainder(diff[3], 2 * M_PI);
    G.col(j) = diff / 2e-6;
  }
  RobotPose& pose = out.pose;
  const Eigen::Vector4d s = robot_state(best, mount, &pose.axes);
  pose.position = s.head<3>();
  pose.yaw = s[3];
  pose.covariance = G * cov6 * G.transpose();
  pose.camera_position = best.c;
  pose.camera_axes = best.R;
  out.ok = pose.position.allFinite() && pose.covariance.allFinite();
  if (!out.ok) out.why = "the solution is not finite";
  return out;
}

}  // namespace ips
