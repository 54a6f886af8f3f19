// The bundle adjustment of `ips survey` (Ceres: the one file that includes it).
//
// Unknowns: each camera's pose (angle-axis world -> camera, optical centre), each wand
// instant's marker pose (angle-axis marker -> world, centre), each reference's heading (its
// centre is known, it lies flat). Residual of a corner: the angle between the observed ray
// (the mean corner pixel through the camera's intrinsics) and the ray to the modelled corner,
// times the focal length: about the reprojection error in pixels for a fisheye or a pinhole
// alike, without reimplementing the lens. A Huber loss keeps a bad corner from dragging.
#include <cmath>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>

#include "ips/core/error.h"
#include "survey/views.h"

namespace ips::survey {
namespace {

using detail::Target;
using detail::View;

/// The tangent-plane residual of one corner; `corner_world` is templated so the wand and
/// the reference costs share it.
struct RayResidual {
  Eigen::Vector3d e1, e2;  ///< orthonormal basis of the plane perpendicular to the observed ray
  double f = 1.0;          ///< pixels per radian

  RayResidual(const Eigen::Vector3d& ray, double focal) : f(focal) {
    const Eigen::Vector3d a = std::abs(ray.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    e1 = ray.cross(a).normalized();
    e2 = ray.cross(e1).normalized();
  }

  template <typename T>
  void operator()(const T* cam, const T* X, T* r) const {
    T d[3] = {X[0] - cam[3], X[1] - cam[4], X[2] - cam[5]};
    T xc[3];
    ceres::AngleAxisRotatePoint(cam, d, xc);
    const T n = ceres::sqrt(xc[0] * xc[0] + xc[1] * xc[1] + xc[2] * xc[2]);
    r[0] = T(f) * (T(e1.x()) * xc[0] + T(e1.y()) * xc[1] + T(e1.z()) * xc[2]) / n;
    r[1] = T(f) * (T(e2.x()) * xc[0] + T(e2.y()) * xc[1] + T(e2.z()) * xc[2]) / n;
  }
};

struct WandCorner {
  RayResidual ray;
  Eigen::Vector3d corner;  ///< in the marker frame
  template <typename T>
  bool operator()(const T* cam, const T* wand, T* r) const {
    const T c[3] = {T(corner.x()), T(corner.y()), T(corner.z())};
    T X[3];
    ceres::AngleAxisRotatePoint(wand, c, X);
    for (int i = 0; i < 3; ++i) X[i] += wand[3 + i];
    ray(cam, X, r);
    return true;
  }
};

struct ReferenceCorner {
  RayResidual ray;
  Eigen::Vector3d corner;  ///< in the marker frame
  Eigen::Vector3d known;   ///< the reference's centre, world
  template <typename T>
  bool operator()(const T* cam, const T* yaw, T* r) const {
    const T c = ceres::cos(yaw[0]), s = ceres::sin(yaw[0]);
    const T X[3] = {T(known.x()) + c * corner.x() - s * corner.y(), T(known.y()) + s * corner.x() + c * corner.y(),
                    T(known.z()) + T(corner.z())};
    ray(cam, X, r);
    return true;
  }
};

Eigen::Vector3d angle_axis(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d rotation(const double* aa) {
  const Eigen::Vector3d w(aa[0], aa[1], aa[2]);
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

/// Where the rays of the four corners meet z = h, averaged: a flat marker's centre as the
/// `plane` model would place it from this camera.
Eigen::Vector2d floor_centre(const View& v, const Eigen::Matrix3d& R_cw, const Eigen::Vector3d& C, double h) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const auto& ray : v.ray) {
    const Eigen::Vector3d d = R_cw.transpose() * ray;
    sum += (C + (h - C.z()) / d.z() * d).head<2>() / 4.0;
  }
  return sum;
}

}  // namespace

SurveyResult run_survey(const SurveyInput& input) {
  const std::vector<Target> targets = detail::make_targets(input);
  std::vector<Eigen::Matrix3d> R_cw;
  std::vector<Eigen::Vector3d> centre;
  detail::initial_poses(input, targets, R_cw, centre);

  const std::size_t nc = input.cameras.size();
  std::vector<std::array<double, 6>> cam(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    const Eigen::Vector3d w = angle_axis(R_cw[c]);
    cam[c] = {w.x(), w.y(), w.z(), centre[c].x(), centre[c].y(), centre[c].z()};
  }
  // Each target's initial pose from its first view.
  std::vector<std::array<double, 6>> wand(targets.size());
  std::vector<double> yaw(targets.size(), 0.0);
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const View& v = targets[i].views.front();
    const auto c = static_cast<std::size_t>(v.camera);
    const Eigen::Matrix3d R_wm = R_cw[c].transpose() * v.R_cm;
    const Eigen::Vector3d p = centre[c] + R_cw[c].transpose() * v.t_cm;
    const Eigen::Vector3d w = angle_axis(R_wm);
    wand[i] = {w.x(), w.y(), w.z(), p.x(), p.y(), p.z()};
    yaw[i] = std::atan2(R_wm(1, 0), R_wm(0, 0));
  }

  using Params = std::vector<std::array<double, 6>>;
  struct Block {
    std::size_t camera;
    ceres::ResidualBlockId id;
  };
  // Every corner's residual, but those of reference `skip` (leave-one-out check).
  auto build = [&](ceres::Problem& problem, Params& cams, Params& wands, std::vector<double>& yaws, int skip) {
    std::vector<Block> out;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const Target& t = targets[i];
      if (t.reference >= 0 && t.reference == skip) continue;
      const auto corners = detail::marker_corners(t.edge);
      for (const View& v : t.views) {
        const auto c = static_cast<std::size_t>(v.camera);
        const double f = input.cameras[c].intrinsics.K()(0, 0);
        for (std::size_t k = 0; k < 4; ++k) {
          ceres::LossFunction* loss = new ceres::HuberLoss(input.huber_px);
          ceres::ResidualBlockId id;
          if (t.reference >= 0) {
            const auto& known = input.references[static_cast<std::size_t>(t.reference)].position;
            auto* cost = new ceres::AutoDiffCostFunction<ReferenceCorner, 2, 6, 1>(
                new ReferenceCorner{RayResidual(v.ray[k], f), corners[k], known});
            id = problem.AddResidualBlock(cost, loss, cams[c].data(), &yaws[i]);
          } else {
            auto* cost = new ceres::AutoDiffCostFunction<WandCorner, 2, 6, 6>(
                new WandCorner{RayResidual(v.ray[k], f), corners[k]});
            id = problem.AddResidualBlock(cost, loss, cams[c].data(), wands[i].data());
          }
          out.push_back({c, id});
        }
      }
    }
    return out;
  };
  ceres::Problem problem;
  const std::vector<Block> blocks = build(problem, cam, wand, yaw, -1);

  auto rms_by_camera = [&](std::vector<double>& per_camera, std::vector<int>& n) {
    per_camera.assign(nc, 0.0);
    n.assign(nc, 0);
    double total = 0.0;
    int all = 0;
    for (const Block& b : blocks) {
      double cost = 0.0;
      double r[2];
      problem.EvaluateResidualBlock(b.id, false, &cost, r, nullptr);
      per_camera[b.camera] += r[0] * r[0] + r[1] * r[1];
      total += r[0] * r[0] + r[1] * r[1];
      ++n[b.camera];
      ++all;
    }
    for (std::size_t c = 0; c < nc; ++c) per_camera[c] = n[c] ? std::sqrt(per_camera[c] / n[c]) : 0.0;
    return all ? std::sqrt(total / all) : 0.0;
  };
  SurveyResult out;
  std::vector<double> rms;
  std::vector<int> corners;
  out.initial_rms_px = rms_by_camera(rms, corners);

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) throw InputError("the bundle adjustment failed: " + summary.message);
  out.iterations = static_cast<int>(summary.iterations.size());
  out.final_rms_px = rms_by_camera(rms, corners);
  out.instants = static_cast<int>(targets.size());

  // Uncertainty of each camera centre: the covariance of its block, scaled by the
  // residuals' own variance (the corner noise is not known beforehand).
  double ss = 0.0;
  for (std::size_t c = 0; c < nc; ++c) ss += rms[c] * rms[c] * corners[c];
  const int dof = 2 * static_cast<int>(blocks.size()) - problem.NumParameters();
  const double s2 = dof > 0 ? 2.0 * ss / dof : 0.0;  // rms is per corner (2 residuals)
  ceres::Covariance::Options copt;
  copt.algorithm_type = ceres::DENSE_SVD;
  copt.null_space_rank = -1;
  ceres::Covariance covariance(copt);
  std::vector<std::pair<const double*, const double*>> wanted;
  for (std::size_t c = 0; c < nc; ++c) wanted.emplace_back(cam[c].data(), cam[c].data());
  const bool cov_ok = covariance.Compute(wanted, &problem);

  for (std::size_t c = 0; c < nc; ++c) {
    CameraResult r;
    r.name = input.cameras[c].name;
    r.model = input.cameras[c].model;
    r.R_wc = rotation(cam[c].data()).transpose();
    r.centre = Eigen::Vector3d(cam[c][3], cam[c][4], cam[c][5]);
    r.rms_px = rms[c];
    r.observations = corners[c] / 4;
    if (cov_ok) {
      double block[36];
      if (covariance.GetCovarianceBlock(cam[c].data(), cam[c].data(), block)) {
        for (int a = 0; a < 3; ++a) r.sigma[a] = std::sqrt(std::max(0.0, block[(3 + a) * 6 + 3 + a] * s2));
        r.covariance_ok = true;
      }
    }
    out.cameras.push_back(r);
  }
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const Target& t = targets[i];
    if (t.reference < 0) {
      out.wand.emplace_back(wand[i][3], wand[i][4], wand[i][5]);
      continue;
    }
    ReferenceResult rr;
    rr.id = t.id;
    rr.known = input.references[static_cast<std::size_t>(t.reference)].position;
    // Left out: the survey solved again without this reference (from the full solution);
    // where its cameras then put it shows how well the references agree with each other.
    Params loo_cam = cam, loo_wand = wand;
    std::vector<double> loo_yaw = yaw;
    ceres::Problem loo;
    build(loo, loo_cam, loo_wand, loo_yaw, t.reference);
    ceres::Solver::Summary loo_summary;
    ceres::Solve(options, &loo, &loo_summary);
    for (const View& v : t.views) {
      const auto c = static_cast<std::size_t>(v.camera);
      ++out.cameras[c].references_seen;
      rr.residual[out.cameras[c].name] =
          floor_centre(v, out.cameras[c].R_wc.transpose(), out.cameras[c].centre, rr.known.z()) - rr.known.head<2>();
      if (loo_summary.IsSolutionUsable())
        rr.left_out[out.cameras[c].name] =
            floor_centre(v, rotation(loo_cam[c].data()), Eigen::Vector3d(loo_cam[c][3], loo_cam[c][4], loo_cam[c][5]),
                         rr.known.z()) -
            rr.known.head<2>();
    }
    out.references.push_back(rr);
  }
  return out;
}

}  // namespace ips::survey
