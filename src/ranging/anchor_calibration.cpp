// An anchor's bias and position from ranges at known tag positions (Ceres, a Huber loss).
#include "ips/ranging/anchor_calibration.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Cholesky>

namespace ips {

const char* anchor_calibration_status_word(AnchorCalibration::Status status) {
  switch (status) {
    case AnchorCalibration::Status::kOk: return "ok";
    case AnchorCalibration::Status::kTooFew: return "too_few";
    case AnchorCalibration::Status::kPoorGeometry: return "poor_geometry";
    case AnchorCalibration::Status::kFailed: return "failed";
  }
  return "failed";
}

const char* anchor_unknowns_word(AnchorUnknowns unknowns) {
  switch (unknowns) {
    case AnchorUnknowns::kPosition: return "position";
    case AnchorUnknowns::kHorizontal: return "horizontal";
    case AnchorUnknowns::kBias: return "bias";
  }
  return "bias";
}

namespace {

// One sample's residual in sigmas (the robust loss's scale is then in sigmas too).
struct SampleResidual {
  AnchorSample s;
  template <typename T>
  bool operator()(const T* xy, const T* z, const T* bias, T* residual) const {
    const T dx = T(s.tag.x()) - xy[0], dy = T(s.tag.y()) - xy[1], dz = T(s.tag.z()) - z[0];
    residual[0] = (ceres::sqrt(dx * dx + dy * dy + dz * dz + T(1e-18)) + bias[0] - T(s.range_m)) / T(s.sigma_m);
    return true;
  }
};

bool usable(const AnchorSample& s) {
  return s.tag.allFinite() && std::isfinite(s.range_m) && s.range_m > 0 && std::isfinite(s.sigma_m) && s.sigma_m > 0;
}

}  // namespace

AnchorCalibration calibrate_anchor(const Eigen::Vector3d& configured, std::span<const AnchorSample> all,
                                   const AnchorCalibrationOptions& options) {
  AnchorCalibration out;
  out.position = configured;
  out.unknowns = options.unknowns;
  // Unknowns: the bias always, then x, y (horizontal), then z (position); the Jacobian's
  // columns in the order x, y, z, bias of what is estimated.
  const int n = options.unknowns == AnchorUnknowns::kPosition     ? 4
                : options.unknowns == AnchorUnknowns::kHorizontal ? 3
                                                                  : 1;
  std::vector<AnchorSample> samples;
  for (const AnchorSample& s : all)
    if (usable(s)) samples.push_back(s);
  out.samples = samples.size();
  if (samples.size() < (n > 1 ? std::max<std::size_t>(options.min_samples, 4) : 1)) {
    out.status = AnchorCalibration::Status::kTooFew;
    return out;
  }
  double xy[2] = {configured.x(), configured.y()};
  double z[1] = {configured.z()};
  double bias[1] = {0.0};
  ceres::Problem problem;
  for (const AnchorSample& s : samples) {
    ceres::LossFunction* loss = options.robust_sigmas > 0 ? new ceres::HuberLoss(options.robust_sigmas) : nullptr;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SampleResidual, 1, 2, 1, 1>(new SampleResidual{s}), loss,
                             xy, z, bias);
  }
  if (n < 3) problem.SetParameterBlockConstant(xy);
  if (n < 4) problem.SetParameterBlockConstant(z);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 100;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  const Eigen::Vector3d a(xy[0], xy[1], z[0]);
  if (!summary.IsSolutionUsable() || !a.allFinite() || !std::isfinite(bias[0])) return out;  // kFailed
  out.position = a;
  out.bias_m = bias[0];

  // The information of the samples within the robust limit, and how well they fit.
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(n, n);
  double chi2 = 0, squares = 0;
  std::size_t inliers = 0;
  for (const AnchorSample& s : samples) {
    const Eigen::Vector3d d = s.tag - a;
    const double distance = std::max(d.norm(), 1e-9);
    const double e = distance + out.bias_m - s.range_m;
    if (options.robust_sigmas > 0 && std::abs(e) > options.robust_sigmas * s.sigma_m) {
      ++out.outliers;
      continue;
    }
    Eigen::VectorXd j(n);
    if (n > 1) j.head(n - 1) = (-d / distance).head(n - 1);
    j(n - 1) = 1.0;
    information += j * j.transpose() / (s.sigma_m * s.sigma_m);
    chi2 += e * e / (s.sigma_m * s.sigma_m);
    squares += e * e;
    ++inliers;
  }
  if (inliers < static_cast<std::size_t>(n)) {
    out.status = AnchorCalibration::Status::kTooFew;
    return out;
  }
  out.rms_m = std::sqrt(squares / static_cast<double>(inliers));
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(information);
  const Eigen::MatrixXd covariance = ldlt.solve(Eigen::MatrixXd::Identity(n, n));
  const Eigen::VectorXd geometry_sigma = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  const double dof = static_cast<double>(inliers) - n;
  const double scale = dof > 0 ? std::sqrt(std::max(1.0, chi2 / dof)) : 1.0;
  out.sigma.head(n - 1) = scale * geometry_sigma.head(n - 1);
  out.sigma(3) = scale * geometry_sigma(n - 1);
  const bool determined = ldlt.info() == Eigen::Success && geometry_sigma.allFinite() &&
                          geometry_sigma.maxCoeff() <= options.max_sigma_m && ldlt.vectorD().minCoeff() > 0;
  out.status = determined ? AnchorCalibration::Status::kOk : AnchorCalibration::Status::kPoorGeometry;
  return out;
}

}  // namespace ips

namespace ips {

AnchorCalibration calibrate_anchor_best(const Eigen::Vector3d& configured, std::span<const AnchorSample> samples,
                                        AnchorCalibrationOptions options) {
  for (;;) {
    AnchorCalibration c = calibrate_anchor(configured, samples, options);
    // Poorly determined, or so far off that most samples fell outside the robust limit: fewer unknowns.
    if (c.status == AnchorCalibration::Status::kOk || options.unknowns == AnchorUnknowns::kBias) return c;
    options.unknowns =
        options.unknowns == AnchorUnknowns::kPosition ? AnchorUnknowns::kHorizontal : AnchorUnknowns::kBias;
  }
}

}  // namespace ips
