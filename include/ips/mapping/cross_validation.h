// Cross-validation of a mapping method on one camera's pairs.
#pragma once

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/mapping/error_stats.h"
#include "ips/mapping/mapper.h"

namespace ips {

/// Fold of each of `n` points for k-fold cross-validation: point i goes to fold i mod k
/// (interleaved, deterministic; calibration files are usually written in a sweep across
/// the floor, so interleaving spreads every fold over the whole area). k >= n means
/// leave-one-out. Throws ips::InputError if k < 2.
std::vector<int> fold_assignment(std::size_t n, int folds);

/// Predicts every point with `method` fitted on the other folds (folds = 0: leave-one-out).
/// The row's world z is passed as the known height (used by `plane` only).
/// Throws ips::InputError if a training fold is too small for the method.
std::vector<Eigen::Vector3d> cross_validated_predictions(const std::string& method,
                                                         std::span<const Eigen::Vector3d> cam,
                                                         std::span<const Eigen::Vector3d> world, int folds,
                                                         const FitOptions& options);

/// Error statistics of cross_validated_predictions().
CameraErrors cross_validate(const std::string& method, std::span<const Eigen::Vector3d> cam,
                            std::span<const Eigen::Vector3d> world, int folds, const FitOptions& options);

/// Predicts every point with a fitted mapper, the row's world z as the known height.
std::vector<Eigen::Vector3d> predict_points(const Mapper& mapper, std::span<const Eigen::Vector3d> cam,
                                            std::span<const Eigen::Vector3d> world);

}  // namespace ips
