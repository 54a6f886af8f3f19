#pragma once
// Positions from ranges to known points (UWB or ultrasound anchors, or other robots acting as
// anchors): the two published solvers this project implements.
//  - Albayati & Kurt (2019), "Assisting 3D Indoor Positioning for Robot Navigation": every
//    4-subset of the references solved in closed form (the spheres linearised against the
//    first one, eq. 9: x = M^-1 b), and the position taken as the per-axis median (or mean) of
//    the candidates; their Table 1: the median beats the mean.
//  - Petković et al. (2016): the position minimising F = sum_i (|p_i - p| - d_i)^2. Here
//    weighted by each range's sigma, optionally robust (Cauchy loss, and ranges the others
//    contradict left out), solved by Ceres from the
//    subsets' median, with the covariance of the solution (J^T W J)^-1.
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace ips {

/// One measured range: where the reference is, how far it measured, how much to trust it.
struct RangeToAnchor {
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();  ///< reference position, world frame (m)
  double range_m = 0;                                ///< measured distance (m)
  double sigma_m = 0.1;                              ///< 1-sigma of the range (m), > 0
};

/// Why a fix failed, as one word for files and scripts (range_fix_status_word).
enum class RangeFixStatus { kOk, kTooFew, kBadRange, kCoplanar, kCollinear, kTooMany, kFailed };
const char* range_fix_status_word(RangeFixStatus status);  // ok, too_few, bad_range, coplanar, ...

/// A position solved from ranges.
struct RangeFix {
  bool ok = false;
  RangeFixStatus status = RangeFixStatus::kFailed;
  std::string why;  ///< when !ok: what made it unsolvable (too few references, all coplanar, ...)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// 1-sigma uncertainty of `position` (m^2) from the ranges' sigmas and the geometry. A fixed
  /// height (RangeSolveOptions::known_height) has zero variance.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double rms_residual_m = 0;  ///< RMS of |anchor - position| - range over the ranges used
  int ranges_used = 0;
  int ranges_rejected = 0;  ///< least squares: ranges left out as contradicted by the others (not in ranges_used)
  int subsets_solved = 0;   ///< the subset solver: 4-subsets (or 3-subsets at a known height) that gave a candidate
};

/// Albayati & Kurt's eq. (9) for exactly four references: the unique point whose distances
/// satisfy the three sphere differences. nullopt when the four are (nearly) coplanar, where
/// the linearised system has no unique solution.
std::optional<Eigen::Vector3d> solve_four_ranges(std::span<const RangeToAnchor> four);

/// The same at a known height: three references, two unknowns (x, y). nullopt when the three
/// are (nearly) collinear seen from above.
std::optional<Eigen::Vector3d> solve_three_ranges_at_height(std::span<const RangeToAnchor> three, double z);

enum class SubsetVote { kMedian, kMean };

struct RangeSolveOptions {
  /// The tag's height when it is known (a robot on a floor): solve x, y only. Anchors at one
  /// height (a common installation) cannot tell above from below, nor, with every 4-subset
  /// coplanar, be solved in 3-D at all.
  std::optional<double> known_height;
  /// Otherwise, the heights the tag can be at (least squares and Nelder-Mead only): with
  /// anchors in one plane and the range on one side of it, the mirror image is excluded and
  /// the fix is solved in 3-D.
  std::optional<std::pair<double, double>> z_range;
  /// Least squares: ranges with a residual beyond this many sigmas weigh less and less (a
  /// Cauchy loss at this scale); 0 = plain least squares, as Petković et al.
  double robust_sigmas = 2.0;
  /// With the robust loss: while a range is off by more than this many sigmas and at least
  /// three more ranges than unknowns are left, the range whose removal leaves the most
  /// consistent set is left out (RangeFix::ranges_rejected); 0 = never.
  double reject_sigmas = 4.0;
};

/// Every 4-subset (3-subset at a known height) solved in closed form, combined per axis by
/// `vote`. Covariance: the candidates' spread per axis (their sample variance), rms over all
/// ranges. Needs >= 4 ranges (3 at a known height) not all in one plane (line).
RangeFix fix_from_subsets(std::span<const RangeToAnchor> ranges, SubsetVote vote,
                          const RangeSolveOptions& options = {});

/// Weighted least squares over all ranges, started from `initial` or, without one, from the
/// subsets' median (then from the anchors' centroid if no subset solves). Covariance
/// (J^T W J)^-1 at the solution.
RangeFix fix_least_squares(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options = {},
                           const std::optional<Eigen::Vector3d>& initial = std::nullopt);

/// Petković et al.'s own method: F = sum_i (|p_i - p| - d_i)^2 (unweighted) minimised by
/// Nelder-Mead (NLopt LN_NELDERMEAD), started as fix_least_squares. Covariance as there.
RangeFix fix_nelder_mead(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options = {},
                         const std::optional<Eigen::Vector3d>& initial = std::nullopt);

/// The solvers by the names `ips trilaterate --method` and `ranging.method` use: robust (the
/// default: fix_least_squares as configured), lsq (plain weighted least squares), median4 and
/// mean4 (fix_from_subsets), nelder-mead (fix_nelder_mead).
const std::vector<std::string>& range_method_names();
/// Solves by name; throws ips::InputError naming `where` for an unknown one.
RangeFix fix_by_method(const std::string& method, std::span<const RangeToAnchor> ranges, RangeSolveOptions options,
                       const std::string& where = "method");

}  // namespace ips
