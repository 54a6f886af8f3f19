#include "ips/insideout/map_builder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>

#include "ips/core/error.h"
#include "ips/insideout/localise.h"

namespace ips {
namespace {
// Named inside the anonymous namespace: unity builds put this file beside others.
namespace ceiling_mapping {

// A marker's unknowns: centre x, y, z and the heading of its printed x axis (face down).
using MarkerParams = std::array<double, 4>;
// A frame's camera: angle-axis world -> camera, then the lens centre in the world.
using CameraParams = std::array<double, 6>;

// Corner offsets in marker units, ArUco order (as ceiling_map.cpp).
constexpr double kCornerUnits[4][2] = {{-0.5, 0.5}, {0.5, 0.5}, {0.5, -0.5}, {-0.5, -0.5}};

// The observed ray of a corner against the modelled corner: the tangent-plane error of their
// directions times the focal length, about the reprojection error in pixels for any lens.
struct CeilingCorner {
  Eigen::Vector3d e1, e2;  // basis of the plane perpendicular to the observed ray
  double f = 1.0, a = 0.0, b = 0.0, length = 0.2;

  CeilingCorner(const Eigen::Vector3d& ray, double focal, double a_, double b_, double len)
      : f(focal), a(a_), b(b_), length(len) {
    const Eigen::Vector3d axis = std::abs(ray.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    e1 = ray.cross(axis).normalized();
    e2 = ray.cross(e1).normalized();
  }

  template <typename T>
  bool operator()(const T* cam, const T* m, T* r) const {
    using std::cos;
    using std::sin;
    const T c = cos(m[3]), s = sin(m[3]);
    // Face down: printed x = (c, s, 0), printed y = normal x x = (s, -c, 0).
    const T d[3] = {m[0] + T(length) * (T(a) * c + T(b) * s) - cam[3],
                    m[1] + T(length) * (T(a) * s - T(b) * c) - cam[4], m[2] - cam[5]};
    T xc[3];
    ceres::AngleAxisRotatePoint(cam, d, xc);
    const T n = ceres::sqrt(xc[0] * xc[0] + xc[1] * xc[1] + xc[2] * xc[2]);
    r[0] = T(f) * (T(e1.x()) * xc[0] + T(e1.y()) * xc[1] + T(e1.z()) * xc[2]) / n;
    r[1] = T(f) * (T(e2.x()) * xc[0] + T(e2.y()) * xc[1] + T(e2.z()) * xc[2]) / n;
    return true;
  }
};

CameraParams to_params(const Eigen::Matrix3d& R_wc, const Eigen::Vector3d& centre) {
  const Eigen::Matrix3d R_cw = R_wc.transpose();
  double aa[3];
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(R_cw.data()), aa);
  return {aa[0], aa[1], aa[2], centre.x(), centre.y(), centre.z()};
}

Eigen::Matrix3d camera_axes(const CameraParams& p) {
  Eigen::Matrix3d R_cw;
  ceres::AngleAxisToRotationMatrix(p.data(), ceres::ColumnMajorAdapter3x3(R_cw.data()));
  return R_cw.transpose();
}

// A marker seen for the first time, placed from one view: IPPE's candidate whose face looks
// most nearly down (the ceiling), turned exactly face down.
std::optional<MarkerParams> place_marker(const MarkerDetection& d, double length, const CameraModel& camera,
                                         const Eigen::Matrix3d& R_wc, const Eigen::Vector3d& centre) {
  std::optional<MarkerParams> best;
  double best_down = -2;
  for (const MarkerInCamera& v : marker_in_camera(d, length, camera)) {
    const Eigen::Matrix3d R_wm = R_wc * v.R;
    const Eigen::Vector3d p = centre + R_wc * v.centre;
    const double down = -R_wm(2, 2);
    if (down > best_down && p.allFinite()) {
      best_down = down;
      best = MarkerParams{p.x(), p.y(), p.z(), std::atan2(R_wm(1, 0), R_wm(0, 0))};
    }
  }
  return best;
}

CeilingMap as_map(const std::map<int, MarkerParams>& markers, const MapBuildOptions& o) {
  CeilingMap map;
  map.dictionary = o.dictionary;
  for (const auto& [id, p] : markers) {
    CeilingMarker m;
    m.id = id;
    m.centre = {p[0], p[1], p[2]};
    m.yaw = std::remainder(p[3], 2 * M_PI);
    m.length = o.sizes.length_of(id);
    map.markers.push_back(m);
  }
  return map;
}

// Each adjusted marker's covariance (x, y, z, yaw) relative to the held one, in the adjustment's
// frame: Ceres' covariance of the parameter blocks (the cameras marginalised), scaled by the
// corner noise the residuals show (their sum of squares over the degrees of freedom). The held
// marker's is zero. Empty when the adjustment leaves some direction free (rank deficient).
std::map<int, Eigen::Matrix4d> marker_covariances(ceres::Problem& problem, std::map<int, MarkerParams>& markers,
                                                  double sum_squares, std::size_t residuals) {
  std::map<int, Eigen::Matrix4d> out;
  std::vector<std::pair<const double*, const double*>> blocks;
  int held = 0;
  for (auto& [id, p] : markers) {
    if (!problem.HasParameterBlock(p.data())) continue;
    if (problem.IsParameterBlockConstant(p.data()))
      held += 4;
    else
      blocks.emplace_back(p.data(), p.data());
  }
  const double dof = static_cast<double>(residuals) - (problem.NumParameters() - held);
  if (blocks.empty() || dof <= 0) return out;
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.num_threads = 2;
  ceres::Covariance covariance(co);
  if (!covariance.Compute(blocks, &problem)) return out;
  const double variance = sum_squares / dof;
  for (auto& [id, p] : markers) {
    if (!problem.HasParameterBlock(p.data())) continue;
    Eigen::Matrix<double, 4, 4, Eigen::RowMajor> c = Eigen::Matrix4d::Zero();
    if (!problem.IsParameterBlockConstant(p.data())) covariance.GetCovarianceBlock(p.data(), p.data(), c.data());
    out[id] = variance * c;
  }
  return out;
}

}  // namespace ceiling_mapping
}  // namespace

MapBuildResult build_ceiling_map(const std::vector<DriveFrame>& frames, const CameraModel& camera,
                                 const std::vector<MapReference>& references, const MapBuildOptions& options) {
  using namespace ceiling_mapping;
  MapBuildResult out;
  out.frames = static_cast<int>(frames.size());
  std::map<int, MarkerParams> markers;
  std::vector<std::optional<CameraParams>> cams(frames.size());

  // (1) Chain. The first frame with a marker fixes the provisional frame: its lens at the
  // origin looking straight up.
  auto add_new_markers = [&](const DriveFrame& f, const Eigen::Matrix3d& R_wc, const Eigen::Vector3d& c) {
    for (const auto& d : f.markers) {
      if (markers.count(d.id)) continue;
      if (const auto p = place_marker(d, options.sizes.length_of(d.id), camera, R_wc, c)) markers[d.id] = *p;
    }
  };
  for (std::size_t i = 0; i < frames.size() && markers.empty(); ++i) {
    if (frames[i].markers.empty()) continue;
    add_new_markers(frames[i], Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
    if (!markers.empty()) cams[i] = to_params(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  }
  if (markers.empty()) throw InputError("no frame of the drive shows a marker whose corners can be used");
  LocaliseOptions chain;
  chain.outlier_px = 15.0;  // provisional marker poses from single views are a few px off
  // Passes in time order until one places no frame: a frame skipped because it shared no
  // marker with the map yet may share one after a later frame added it.
  for (bool placed_any = true; placed_any;) {
    placed_any = false;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (cams[i] || frames[i].markers.empty()) continue;
      const Localisation l = localise(frames[i].markers, camera, as_map(markers, options), CameraMount{}, chain);
      if (!l.ok) continue;
      cams[i] = to_params(l.pose.camera_axes, l.pose.camera_position);
      add_new_markers(frames[i], l.pose.camera_axes, l.pose.camera_position);
      placed_any = true;
    }
  }

  // (2) Bundle adjustment.
  ceres::Problem problem;
  const double f = camera.K()(0, 0);
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (!cams[i]) continue;
    ++out.frames_used;
    for (const auto& d : frames[i].markers) {
      const auto it = markers.find(d.id);
      if (it == markers.end()) continue;
      for (int k = 0; k < 4; ++k) {
        const Point2 n = camera.undistort(d.corners_px[k]);
        if (!std::isfinite(n.x) || !std::isfinite(n.y)) continue;
        const Eigen::Vector3d ray = Eigen::Vector3d(n.x, n.y, 1.0).normalized();
        auto* cost = new ceres::AutoDiffCostFunction<CeilingCorner, 2, 6, 4>(
            new CeilingCorner(ray, f, kCornerUnits[k][0], kCornerUnits[k][1], options.sizes.length_of(d.id)));
        problem.AddResidualBlock(cost, new ceres::HuberLoss(options.huber_px), cams[i]->data(), it->second.data());
        ++out.corners;
      }
    }
    if (problem.HasParameterBlock(cams[i]->data())) ordering->AddElementToGroup(cams[i]->data(), 0);
  }
  for (auto& [id, p] : markers) {
    if (problem.HasParameterBlock(p.data())) ordering->AddElementToGroup(p.data(), 1);
  }
  // The gauge: a face-down ceiling leaves x, y, z and a turn about the vertical free.
  problem.SetParameterBlockConstant(markers.begin()->second.data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;  // cameras eliminated, the markers' system is small
  so.linear_solver_ordering.reset(ordering);
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 2;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  ceres::Problem::EvaluateOptions eo;
  eo.apply_loss_function = false;
  std::vector<double> residuals;
  problem.Evaluate(eo, nullptr, &residuals, nullptr, nullptr);
  double sum = 0;
  for (double r : residuals) sum += r * r;
  out.rms_px = out.corners > 0 ? std::sqrt(sum / out.corners) : 0.0;
  const std::map<int, Eigen::Matrix4d> covariances = marker_covariances(problem, markers, sum, residuals.size());
  out.anchor = markers.begin()->first;

  // (3) Onto the references: a turn about the vertical and a shift.
  std::vector<std::pair<const MapReference*, const MarkerParams*>> pairs;
  for (const auto& r : references) {
    const auto it = markers.find(r.id);
    if (it == markers.end()) {
      throw InputError("reference " + std::to_string(r.id) +
                       ": no frame of the drive placed it (seen: " + std::to_string(markers.size()) + " markers)");
    }
    pairs.emplace_back(&r, &it->second);
  }
  double theta = 0;
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  const MapReference* with_yaw = nullptr;
  for (const auto& [r, m] : pairs) {
    if (r->yaw) with_yaw = r;
  }
  if (pairs.size() >= 2) {
    // 2-D Procrustes on the centres (no scale: the markers' edge length is the scale).
    Eigen::Vector2d mean_m = Eigen::Vector2d::Zero(), mean_r = Eigen::Vector2d::Zero();
    double dz = 0;
    for (const auto& [r, m] : pairs) {
      mean_m += Eigen::Vector2d((*m)[0], (*m)[1]);
      mean_r += r->position.head<2>();
      dz += r->position.z() - (*m)[2];
    }
    const double n = static_cast<double>(pairs.size());
    mean_m /= n;
    mean_r /= n;
    double sxx = 0, sxy = 0;
    for (const auto& [r, m] : pairs) {
      const Eigen::Vector2d a = Eigen::Vector2d((*m)[0], (*m)[1]) - mean_m, b = r->position.head<2>() - mean_r;
      sxx += a.dot(b);
      sxy += a.x() * b.y() - a.y() * b.x();
    }
    theta = std::atan2(sxy, sxx);
    const Eigen::Vector2d t = mean_r - Eigen::Rotation2Dd(theta) * mean_m;
    shift = {t.x(), t.y(), dz / n};
  } else if (with_yaw != nullptr) {
    const MarkerParams& m = *pairs.front().second;
    theta = *with_yaw->yaw - m[3];
    const Eigen::Vector2d t = with_yaw->position.head<2>() - Eigen::Rotation2Dd(theta) * Eigen::Vector2d(m[0], m[1]);
    shift = {t.x(), t.y(), with_yaw->position.z() - m[2]};
  } else {
    throw InputError("the references place the map only with >= 2 markers' centres, or one with its yaw (got " +
                     std::to_string(pairs.size()) + " without a yaw)");
  }
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (auto& [id, p] : markers) {
    const Eigen::Vector3d c = Rz * Eigen::Vector3d(p[0], p[1], p[2]) + shift;
    p = {c.x(), c.y(), c.z(), p[3] + theta};
  }
  out.map = as_map(markers, options);
  // The uncertainties turned with the map (x, y); z and the heading are unchanged by a turn.
  const Eigen::Matrix2d R2 = Rz.topLeftCorner<2, 2>();
  for (CeilingMarker& m : out.map.markers) {
    const auto it = covariances.find(m.id);
    if (it == covariances.end()) continue;
    const Eigen::Matrix2d xy = R2 * it->second.topLeftCorner<2, 2>() * R2.transpose();
    m.sigma = Eigen::Vector4d(std::sqrt(std::max(0.0, xy(0, 0))), std::sqrt(std::max(0.0, xy(1, 1))),
                              std::sqrt(std::max(0.0, it->second(2, 2))), std::sqrt(std::max(0.0, it->second(3, 3))));
  }
  for (const auto& [r, m] : pairs) {
    ReferenceResidual rr;
    rr.id = r->id;
    rr.offset = Eigen::Vector3d((*m)[0], (*m)[1], (*m)[2]) - r->position;
    if (r->yaw) rr.yaw_offset = std::remainder((*m)[3] - *r->yaw, 2 * M_PI);
    out.references.push_back(rr);
  }
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (!cams[i]) {
      for (const auto& d : frames[i].markers) {
        if (!markers.count(d.id) &&
            std::find(out.unconnected.begin(), out.unconnected.end(), d.id) == out.unconnected.end())
          out.unconnected.push_back(d.id);
      }
      continue;
    }
    const Eigen::Matrix3d R = Rz * camera_axes(*cams[i]);
    const Eigen::Vector3d c = Rz * Eigen::Vector3d((*cams[i])[3], (*cams[i])[4], (*cams[i])[5]) + shift;
    out.cameras.push_back({frames[i].t_ns, c, std::atan2(R(1, 0), R(0, 0))});
  }
  std::sort(out.unconnected.begin(), out.unconnected.end());
  return out;
}

}  // namespace ips
