// Internal: constructors of the concrete mappers behind the registry (registry.cpp).
#pragma once

#include <memory>
#include <span>

#include <Eigen/Core>

#include "ips/mapping/mapper.h"

namespace ips::mapping {

std::unique_ptr<Mapper> make_rigid();                                 ///< "rt"
std::unique_ptr<Mapper> make_polynomial();                            ///< "pr"
std::unique_ptr<Mapper> make_ann();                                   ///< "ann"
std::unique_ptr<Mapper> make_kriging(bool regression);                ///< "ki" / "kr"
std::unique_ptr<Mapper> make_chained(std::unique_ptr<Mapper> inner);  ///< "rt+<inner>"
std::unique_ptr<Mapper> make_plane();                                 ///< "plane"
std::unique_ptr<Mapper> make_auto();                                  ///< "auto"

/// Kabsch: the rotation R (det +1) and translation t minimising sum |R a_i + t - b_i|^2.
/// Throws ips::InputError if the points are (nearly) collinear.
void kabsch(std::span<const Eigen::Vector3d> a, std::span<const Eigen::Vector3d> b, Eigen::Matrix3d& R,
            Eigen::Vector3d& t);

/// Throws ips::InputError unless cam and world have the same size >= min_points.
void check_fit_input(const Mapper& mapper, std::span<const Eigen::Vector3d> cam,
                     std::span<const Eigen::Vector3d> world);

}  // namespace ips::mapping
