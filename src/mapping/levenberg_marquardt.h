// A small dense Levenberg–Marquardt least-squares solver (ann training, plane pose).
#pragma once

#include <functional>

#include <Eigen/Core>

namespace ips::mapping {

/// Computes residuals r(p) and, when `jacobian` is not null, dr/dp (rows = residuals).
using ResidualFunction = std::function<void(const Eigen::VectorXd& p, Eigen::VectorXd& r, Eigen::MatrixXd* jacobian)>;

struct LmOptions {
  int max_iterations = 200;           ///< accepted + rejected steps
  double initial_damping = 1e-3;      ///< mu at the start (MATLAB trainlm also starts at 1e-3)
  double max_damping = 1e10;          ///< give up when mu grows beyond this (no descent possible)
  double relative_tolerance = 1e-12;  ///< stop when a step lowers the cost by less than this fraction
  /// true: damp with mu * diag(J^T J) (Marquardt, scale invariant); false: mu * I (trainlm).
  bool scale_damping = false;
};

struct LmResult {
  Eigen::VectorXd params;
  double cost = 0.0;  ///< 0.5 * |r|^2 at params
  int iterations = 0;
};

LmResult levenberg_marquardt(const ResidualFunction& f, Eigen::VectorXd p0, const LmOptions& options);

/// Central-difference Jacobian of a residual function that ignores its `jacobian` argument.
Eigen::MatrixXd numeric_jacobian(const ResidualFunction& f, const Eigen::VectorXd& p, Eigen::Index residual_count);

}  // namespace ips::mapping
