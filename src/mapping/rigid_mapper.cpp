// `rt`: rigid transform (rotation + translation, no scale) by the SVD of the centred
// cross-covariance (Kabsch/Arun), with the reflection case handled.
#include <Eigen/LU>
#include <Eigen/SVD>
#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "mapping/json_params.h"
#include "mapping/mappers.h"

namespace ips::mapping {

void check_fit_input(const Mapper& mapper, std::span<const Eigen::Vector3d> cam,
                     std::span<const Eigen::Vector3d> world) {
  if (cam.size() != world.size())
    throw InputError(mapper.method() + ": " + std::to_string(cam.size()) + " camera points but " +
                     std::to_string(world.size()) + " world points");
  if (cam.size() < mapper.min_points())
    throw InputError("method '" + mapper.method() + "' needs at least " + std::to_string(mapper.min_points()) +
                     " pairs, got " + std::to_string(cam.size()));
}

void kabsch(std::span<const Eigen::Vector3d> a, std::span<const Eigen::Vector3d> b, Eigen::Matrix3d& R,
            Eigen::Vector3d& t) {
  const double n = static_cast<double>(a.size());
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) {
    ca += a[i];
    cb += b[i];
  }
  ca /= n;
  cb /= n;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) H += (a[i] - ca) * (b[i] - cb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  // Rank < 2 (all points on a line): the rotation about that line is undetermined.
  if (s[1] <= 1e-12 * std::max(s[0], 1e-300))
    throw InputError("rt: the points are collinear; the rotation is undetermined");
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  // If V U^T is a reflection, flip the axis of the smallest singular value (Umeyama).
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((V * U.transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  R = V * D * U.transpose();
  t = cb - R * ca;
}

namespace {

class RigidMapper final : public Mapper {
 public:
  std::string method() const override { return "rt"; }
  std::size_t min_points() const override { return 3; }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world, const FitOptions&) override {
    check_fit_input(*this, cam, world);
    kabsch(cam, world, R_, t_);
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double) const override { return R_ * cam + t_; }

  nlohmann::json to_json() const override { return {{"R", to_json_rows(R_)}, {"t", to_json_array(t_)}}; }

  void from_json(const nlohmann::json& p) override {
    const Eigen::Matrix3d R = get_rows(p, "R", 3, 3);
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-9 || R.determinant() < 0.0)
      throw InputError("parameter 'R': not a rotation matrix");
    R_ = R;
    t_ = get_vector(p, "t", 3);
  }

 private:
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_ = Eigen::Vector3d::Zero();
};

}  // namespace

std::unique_ptr<Mapper> make_rigid() { return std::make_unique<RigidMapper>(); }

}  // namespace ips::mapping
