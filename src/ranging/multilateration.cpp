#include "ips/ranging/multilateration.h"

#include "ips/core/error.h"

#include "ranging/solver_common.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/LU>
#include <Eigen/SVD>

namespace ips {
namespace {

// Below this ratio of the smallest to the largest singular value the references are taken as
// coplanar (collinear at a known height): the linearised system has no unique solution, and
// nearly so, noise of millimetres moves the candidate by metres.
constexpr double kDegenerate = 1e-6;
// The subset solver enumerates every combination: 20 references are 4845 4-subsets.
constexpr std::size_t kMaxSubsetRanges = 20;

// A lab is not 1000 km across: larger values are typos or hostile, and would overflow squares.
constexpr double kMaxMetres = 1e6;

bool valid(const RangeToAnchor& r) {
  return r.anchor.allFinite() && r.anchor.cwiseAbs().maxCoeff() <= kMaxMetres && std::isfinite(r.range_m) &&
         r.range_m >= 0 && r.range_m <= kMaxMetres && std::isfinite(r.sigma_m) && r.sigma_m > 0 &&
         r.sigma_m <= kMaxMetres;
}

// False (with the fix's status and why) if the ranges cannot be solved at all.

// All anchors in one plane (nearly): above and below it give the same ranges.
bool anchors_coplanar(std::span<const RangeToAnchor> ranges) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& r : ranges) mean += r.anchor;
  mean /= static_cast<double>(ranges.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& r : ranges) scatter += (r.anchor - mean) * (r.anchor - mean).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(scatter);
  const auto& sv = svd.singularValues();
  // The scatter's singular values are squared extents: 1e-6 of the largest is 1e-3 in extent.
  return !(sv(0) > 0) || sv(2) / sv(0) < 1e-6;
}

double rms_residual(std::span<const RangeToAnchor> ranges, const Eigen::Vector3d& p) {
  double sum = 0;
  for (const auto& r : ranges) sum += std::pow((r.anchor - p).norm() - r.range_m, 2);
  return ranges.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(ranges.size()));
}

// (J^T W J)^-1 of the range residuals at p: the position's covariance for independent range
// errors of the given sigmas. False when the geometry leaves a direction unconstrained.
bool geometric_covariance(std::span<const RangeToAnchor> ranges, const Eigen::Vector3d& p, bool known_height,
                          Eigen::Matrix3d& covariance) {
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  for (const auto& r : ranges) {
    const Eigen::Vector3d d = p - r.anchor;
    const double n = d.norm();
    if (n < 1e-9) continue;  // on the anchor: the direction is undefined, the range says nothing more
    const Eigen::Vector3d u = d / n;
    info += u * u.transpose() / (r.sigma_m * r.sigma_m);
  }
  covariance.setZero();
  const int dim = known_height ? 2 : 3;
  const Eigen::MatrixXd block = info.topLeftCorner(dim, dim);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(block);
  const auto& s = svd.singularValues();
  if (s(0) <= 0 || s(dim - 1) / s(0) < kDegenerate) return false;
  covariance.topLeftCorner(dim, dim) = block.inverse();
  return true;
}

// Solves A x = b (square) unless A is (nearly) singular.
template <int N>
std::optional<Eigen::Matrix<double, N, 1>> solve_square(const Eigen::Matrix<double, N, N>& a,
                                                        const Eigen::Matrix<double, N, 1>& b) {
  Eigen::JacobiSVD<Eigen::Matrix<double, N, N>> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& s = svd.singularValues();
  if (!(s(0) > 0) || s(N - 1) / s(0) < kDegenerate) return std::nullopt;
  Eigen::Matrix<double, N, 1> x = svd.solve(b);
  if (!x.allFinite()) return std::nullopt;
  return x;
}

double median(std::vector<double> v) {
  const std::size_t n = v.size(), mid = n / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  const double upper = v[mid];
  if (n % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
}

// Calls f with the indices of every k-subset of {0..n-1}.
template <typename F>
void for_each_subset(std::size_t n, std::size_t k, F&& f) {
  std::vector<std::size_t> idx(k);
  std::iota(idx.begin(), idx.end(), 0);
  while (true) {
    f(idx);
    std::size_t i = k;
    while (i > 0 && idx[i - 1] == n - k + i - 1) --i;
    if (i == 0) return;
    ++idx[i - 1];
    for (std::size_t j = i; j < k; ++j) idx[j] = idx[j - 1] + 1;
  }
}

constexpr const char* kCoplanarWhy =
    "the anchors are in one plane: above and below it cannot be told apart (give the tag's height or a z range)";

}  // namespace

namespace ranging_detail {

bool check_input(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options, RangeFix& fix) {
  for (std::size_t i = 0; i < ranges.size(); ++i)
    if (!valid(ranges[i])) {
      fix.status = RangeFixStatus::kBadRange;
      fix.why = "range " + std::to_string(i) + " is not finite, negative, beyond 1000 km, or has no positive sigma";
      return false;
    }
  if (options.z_range && !(std::isfinite(options.z_range->first) && std::isfinite(options.z_range->second) &&
                           options.z_range->first <= options.z_range->second)) {
    fix.status = RangeFixStatus::kBadRange;
    fix.why = "the z range is not [min, max] with min <= max";
    return false;
  }
  const std::size_t needed = options.known_height ? 3 : 4;
  if (ranges.size() < needed) {
    fix.status = RangeFixStatus::kTooFew;
    fix.why = std::to_string(ranges.size()) + " ranges; at least " + std::to_string(needed) + " are needed";
    return false;
  }
  return true;
}

RangeFix finish(RangeFix fix, std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options) {
  fix.ranges_used = static_cast<int>(ranges.size());
  fix.rms_residual_m = rms_residual(ranges, fix.position);
  fix.ok = true;
  fix.status = RangeFixStatus::kOk;
  fix.why.clear();
  // Never a silent mirror image: coplanar anchors need the height, or a z range on one side.
  const bool mirror = !options.known_height && !options.z_range && anchors_coplanar(ranges);
  if (mirror || !geometric_covariance(ranges, fix.position, options.known_height.has_value(), fix.covariance)) {
    fix.ok = false;
    fix.status = options.known_height ? RangeFixStatus::kCollinear : RangeFixStatus::kCoplanar;
    fix.why =
        options.known_height ? "the anchors are in one line seen from above: the position is ambiguous" : kCoplanarWhy;
  }
  return fix;
}

}  // namespace ranging_detail

using ranging_detail::check_input;
using ranging_detail::finish;

std::optional<Eigen::Vector3d> solve_four_ranges(std::span<const RangeToAnchor> four) {
  if (four.size() != 4) return std::nullopt;
  // |x - p_i|^2 = d_i^2 minus the same for p_0: 2 (p_i - p_0) . x = d_0^2 - d_i^2 + |p_i|^2 - |p_0|^2
  // (Albayati & Kurt eq. 9, x = M^-1 b).
  Eigen::Matrix3d m;
  Eigen::Vector3d b;
  const RangeToAnchor& r0 = four[0];
  for (int i = 1; i < 4; ++i) {
    const RangeToAnchor& ri = four[static_cast<std::size_t>(i)];
    m.row(i - 1) = 2.0 * (ri.anchor - r0.anchor).transpose();
    b(i - 1) = r0.range_m * r0.range_m - ri.range_m * ri.range_m + ri.anchor.squaredNorm() - r0.anchor.squaredNorm();
  }
  return solve_square<3>(m, b);
}

std::optional<Eigen::Vector3d> solve_three_ranges_at_height(std::span<const RangeToAnchor> three, double z) {
  if (three.size() != 3) return std::nullopt;
  Eigen::Matrix2d m;
  Eigen::Vector2d b;
  const RangeToAnchor& r0 = three[0];
  for (int i = 1; i < 3; ++i) {
    const RangeToAnchor& ri = three[static_cast<std::size_t>(i)];
    const Eigen::Vector3d d = ri.anchor - r0.anchor;
    m.row(i - 1) = 2.0 * d.head<2>().transpose();
    b(i - 1) = r0.range_m * r0.range_m - ri.range_m * ri.range_m + ri.anchor.squaredNorm() - r0.anchor.squaredNorm() -
               2.0 * z * d.z();
  }
  const auto xy = solve_square<2>(m, b);
  if (!xy) return std::nullopt;
  return Eigen::Vector3d(xy->x(), xy->y(), z);
}

RangeFix fix_from_subsets(std::span<const RangeToAnchor> ranges, SubsetVote vote, const RangeSolveOptions& options) {
  RangeFix fix;
  const std::size_t k = options.known_height ? 3 : 4;
  if (!check_input(ranges, options, fix)) return fix;
  if (ranges.size() > kMaxSubsetRanges) {
    fix.status = RangeFixStatus::kTooMany;
    fix.why = std::to_string(ranges.size()) + " ranges; the subset solver takes at most " +
              std::to_string(kMaxSubsetRanges) + " (use the least-squares solver)";
    return fix;
  }
  std::vector<double> xs, ys, zs;
  std::vector<RangeToAnchor> subset(k);
  for_each_subset(ranges.size(), k, [&](const std::vector<std::size_t>& idx) {
    for (std::size_t j = 0; j < k; ++j) subset[j] = ranges[idx[j]];
    const auto p =
        options.known_height ? solve_three_ranges_at_height(subset, *options.known_height) : solve_four_ranges(subset);
    if (!p) return;
    xs.push_back(p->x());
    ys.push_back(p->y());
    zs.push_back(p->z());
  });
  fix.subsets_solved = static_cast<int>(xs.size());
  if (xs.empty()) {
    fix.status = options.known_height ? RangeFixStatus::kCollinear : RangeFixStatus::kCoplanar;
    fix.why = options.known_height ? "every 3 of the anchors are in one line seen from above"
                                   : "every 4 of the anchors are in one plane (give the tag's height)";
    return fix;
  }
  const auto combine = [&](const std::vector<double>& v) {
    return vote == SubsetVote::kMedian ? median(v) : std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
  };
  fix.position = {combine(xs), combine(ys), combine(zs)};
  return finish(std::move(fix), ranges, options);
}

namespace ranging_detail {

// Where the iterative solvers start: `initial`, else the subsets' median, else the anchors'
// centroid; at the known height, or inside the z range (its middle if the start is not in it).
Eigen::Vector3d starting_point(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options,
                               const std::optional<Eigen::Vector3d>& initial) {
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  if (initial && initial->allFinite()) {
    start = *initial;
  } else {
    RangeFix seed;
    if (ranges.size() <= kMaxSubsetRanges) seed = fix_from_subsets(ranges, SubsetVote::kMedian, options);
    if (seed.subsets_solved > 0) {
      start = seed.position;
    } else {
      for (const auto& r : ranges) start += r.anchor;
      start /= static_cast<double>(ranges.size());
    }
  }
  if (options.known_height) start.z() = *options.known_height;
  if (options.z_range && !options.known_height) {
    const auto [lo, hi] = *options.z_range;
    if (!(start.z() > lo && start.z() < hi)) start.z() = lo < hi ? 0.5 * (lo + hi) : lo;
  }
  return start;
}

}  // namespace ranging_detail

const std::vector<std::string>& range_method_names() {
  static const std::vector<std::string> names = {"robust", "lsq", "median4", "mean4", "nelder-mead"};
  return names;
}

RangeFix fix_by_method(const std::string& method, std::span<const RangeToAnchor> ranges, RangeSolveOptions options,
                       const std::string& where) {
  if (method == "robust") return fix_least_squares(ranges, options);
  if (method == "lsq") {
    options.robust_sigmas = 0;
    return fix_least_squares(ranges, options);
  }
  if (method == "median4") return fix_from_subsets(ranges, SubsetVote::kMedian, options);
  if (method == "mean4") return fix_from_subsets(ranges, SubsetVote::kMean, options);
  if (method == "nelder-mead") return fix_nelder_mead(ranges, options);
  std::string known;
  for (const auto& n : range_method_names()) known += (known.empty() ? "" : ", ") + n;
  throw InputError(where + ": unknown method '" + method + "' (known: " + known + ")");
}

const char* range_fix_status_word(RangeFixStatus status) {
  switch (status) {
    case RangeFixStatus::kOk: return "ok";
    case RangeFixStatus::kTooFew: return "too_few";
    case RangeFixStatus::kBadRange: return "bad_range";
    case RangeFixStatus::kCoplanar: return "coplanar";
    case RangeFixStatus::kCollinear: return "collinear";
    case RangeFixStatus::kTooMany: return "too_many";
    case RangeFixStatus::kFailed: break;
  }
  return "failed";
}

}  // namespace ips
