// What the range solvers share (src/ranging/): input checks, the finishing of a fix (status,
// covariance, the mirror check), and where the iterative solvers start. Not a public API.
#pragma once

#include <optional>
#include <span>

#include <Eigen/Core>

#include "ips/ranging/multilateration.h"

namespace ips::ranging_detail {

/// False (with fix.status and fix.why set) for too few ranges or a bad value.
bool check_input(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options, RangeFix& fix);
/// Sets ranges_used, the residual, the covariance and the status of a fix at fix.position.
RangeFix finish(RangeFix fix, std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options);
/// `initial`, else the subsets' median, else the anchors' centroid; at the known height or in the z range.
Eigen::Vector3d starting_point(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options,
                               const std::optional<Eigen::Vector3d>& initial);

}  // namespace ips::ranging_detail
