// `plane`: for markers whose height is known. The camera's pose in the world (rotation R,
// centre t) is fitted so that the ray through the normalised image point (u, v) =
// (xc/zc, yc/zc) meets the horizontal plane z = zw at (xw, yw); optionally the normalised
// coordinates get a small radial correction (u, v) * (1 + k1 r^2 + k2 r^4) for what the
// intrinsic calibration left over, with the number of terms (0, 1 or 2) chosen by k-fold
// cross-validation of the 2-D error on the training pairs. The depth from the marker size
// (zc) is used only to start the fit (via `rt`), never to predict, which removes its noise.
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/mapping/cross_validation.h"
#include "mapping/json_params.h"
#include "mapping/levenberg_marquardt.h"
#include "mapping/mappers.h"

namespace ips::mapping {
namespace {

/// Most radial terms tried (k1, k2).
constexpr int kMaxRadialTerms = 2;
/// Folds of the cross-validation that picks the number of radial terms.
constexpr int kSelectionFolds = 5;
/// A higher-order model must beat the lower one's CV mean 2-D error by this factor.
constexpr double kSelectionMargin = 0.98;

struct Pose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double k1 = 0.0, k2 = 0.0;
};

/// World direction (not normalised, z component 1 in the camera frame) of the ray of `cam`.
Eigen::Vector3d ray_direction(const Pose& pose, const Eigen::Vector3d& cam) {
  const double u = cam.x() / cam.z(), v = cam.y() / cam.z();
  const double r2 = u * u + v * v;
  const double f = 1.0 + pose.k1 * r2 + pose.k2 * r2 * r2;
  return pose.R * Eigen::Vector3d(u * f, v * f, 1.0);
}

/// Where the ray of camera point `cam` meets z = h, or NaN if it runs parallel/away.
Eigen::Vector2d intersect(const Pose& pose, const Eigen::Vector3d& cam, double h) {
  const Eigen::Vector3d d = ray_direction(pose, cam);
  const double s = (h - pose.t.z()) / d.z();
  if (!(s > 0.0) || !std::isfinite(s)) return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  return pose.t.head<2>() + s * d.head<2>();
}

Pose pose_from_params(const Pose& base, const Eigen::VectorXd& p, int radial_terms) {
  Pose pose;
  const Eigen::Vector3d w = p.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d dR =
      angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  pose.R = base.R * dR;
  pose.t = base.t + p.segment<3>(3);
  pose.k1 = radial_terms >= 1 ? p[6] : 0.0;
  pose.k2 = radial_terms >= 2 ? p[7] : 0.0;
  return pose;
}

Pose fit_pose(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world, int radial_terms) {
  Pose base;
  kabsch(cam, world, base.R, base.t);  // rigid fit of the 3-D points: a good starting pose
  const auto m = static_cast<Eigen::Index>(cam.size());
  const ResidualFunction f = [&](const Eigen::VectorXd& p, Eigen::VectorXd& r, Eigen::MatrixXd*) {
    const Pose pose = pose_from_params(base, p, radial_terms);
    r.resize(2 * m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto& w = world[static_cast<std::size_t>(i)];
      const Eigen::Vector2d xy = intersect(pose, cam[static_cast<std::size_t>(i)], w.z());
      // A ray that misses the plane costs a large finite residual so LM backs off.
      r.segment<2>(2 * i) = xy.allFinite() ? Eigen::Vector2d(xy - w.head<2>()) : Eigen::Vector2d(1e3, 1e3);
    }
  };
  const ResidualFunction with_jacobian = [&](const Eigen::VectorXd& p, Eigen::VectorXd& r, Eigen::MatrixXd* J) {
    f(p, r, nullptr);
    if (J != nullptr) *J = numeric_jacobian(f, p, 2 * m);
  };
  LmOptions lm;
  lm.max_iterations = 100;
  lm.scale_damping = true;
  const LmResult res = levenberg_marquardt(with_jacobian, Eigen::VectorXd::Zero(6 + radial_terms), lm);
  return pose_from_params(base, res.params, radial_terms);
}

double cv_mean_error_2d(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world,
                        int radial_terms) {
  const auto fold = fold_assignment(cam.size(), kSelectionFolds);
  double sum = 0.0;
  for (int k = 0; k < kSelectionFolds; ++k) {
    std::vector<Eigen::Vector3d> tc, tw;
    for (std::size_t i = 0; i < cam.size(); ++i)
      if (fold[i] != k) {
        tc.push_back(cam[i]);
        tw.push_back(world[i]);
      }
    const Pose pose = fit_pose(tc, tw, radial_terms);
    for (std::size_t i = 0; i < cam.size(); ++i)
      if (fold[i] == k) {
        const Eigen::Vector2d xy = intersect(pose, cam[i], world[i].z());
        sum += xy.allFinite() ? (xy - world[i].head<2>()).norm() : 1e3;
      }
  }
  return sum / static_cast<double>(cam.size());
}

class PlaneMapper final : public Mapper {
 public:
  std::string method() const override { return "plane"; }
  std::size_t min_points() const override { return 6; }
  bool needs_height() const override { return true; }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world, const FitOptions&) override {
    check_fit_input(*this, cam, world);
    for (std::size_t i = 0; i < cam.size(); ++i)
      if (!(cam[i].z() > 0.0)) throw InputError("plane: a pair has zc <= 0 (behind the camera)");
    // Radial terms need enough pairs that every selection fold still over-determines them.
    int terms = 0;
    if (cam.size() >= 20) {
      double best = cv_mean_error_2d(cam, world, 0);
      for (int n = 1; n <= kMaxRadialTerms; ++n) {
        const double e = cv_mean_error_2d(cam, world, n);
        if (e < kSelectionMargin * best) {
          best = e;
          terms = n;
        }
      }
    }
    radial_terms_ = terms;
    pose_ = fit_pose(cam, world, terms);
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double known_height) const override {
    if (!std::isfinite(known_height))
      throw InputError(
          "plane: the marker height is needed (the mapper intersects the camera "
          "ray with the plane z = height)");
    const Eigen::Vector2d xy = intersect(pose_, cam, known_height);
    return Eigen::Vector3d(xy.x(), xy.y(), known_height);
  }

  bool world_ray(const Eigen::Vector3d& cam, Eigen::Vector3d& origin, Eigen::Vector3d& direction) const override {
    if (!(cam.z() > 0.0)) return false;
    origin = pose_.t;
    direction = ray_direction(pose_, cam).normalized();
    return direction.allFinite();
  }

  nlohmann::json to_json() const override {
    return {{"R", to_json_rows(pose_.R)},
            {"t", to_json_array(pose_.t)},
            {"radial_terms", radial_terms_},
            {"k1", pose_.k1},
            {"k2", pose_.k2}};
  }

  void from_json(const nlohmann::json& p) override {
    Pose pose;
    pose.R = get_rows(p, "R", 3, 3);
    if ((pose.R.transpose() * pose.R - Eigen::Matrix3d::Identity()).norm() > 1e-9 || pose.R.determinant() < 0.0)
      throw InputError("parameter 'R': not a rotation matrix");
    pose.t = get_vector(p, "t", 3);
    radial_terms_ = get_int(p, "radial_terms", 0, kMaxRadialTerms);
    pose.k1 = get_number(p, "k1");
    pose.k2 = get_number(p, "k2");
    pose_ = pose;
  }

 private:
  Pose pose_;
  int radial_terms_ = 0;
};

}  // namespace

std::unique_ptr<Mapper> make_plane() { return std::make_unique<PlaneMapper>(); }

}  // namespace ips::mapping
