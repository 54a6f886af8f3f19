// Error statistics of a mapper on paired points, as reported in the paper's Tables I/II.
#pragma once

#include <cstddef>
#include <span>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace ips {

/// Summary of a set of non-negative errors, metres.
struct ErrorStats {
  double mean = 0.0;
  double min = 0.0;
  double max = 0.0;
  double std = 0.0;  ///< sample standard deviation (N-1); NaN when N < 2
};

/// Errors of one camera: 3-D |p_hat - p| and 2-D |(x_hat, y_hat) - (x, y)|.
struct CameraErrors {
  std::size_t n = 0;
  ErrorStats err3d;
  ErrorStats err2d;
};

/// Mean, min, max and sample std of `errors` (must not be empty).
ErrorStats summarize_errors(std::span<const double> errors);

/// Compares predictions with the truth, point by point (same length, not empty).
CameraErrors compare_points(std::span<const Eigen::Vector3d> predicted, std::span<const Eigen::Vector3d> truth);

/// {"n": N, "err3d": {"mean","min","max","std"}, "err2d": {...}} in metres
/// (std is null when N < 2).
nlohmann::json errors_to_json(const CameraErrors& errors);

}  // namespace ips
