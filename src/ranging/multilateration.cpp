#include "ips/ranging/multilateration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <ceres/ceres.h>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <nlopt.hpp>

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

// The residual of one range, in sigmas (so that the robust loss's scale is in sigmas too).
struct RangeResidual {
  RangeToAnchor r;
  template <typename T>
  bool operator()(const T* xy, const T* z, T* residual) const {
    const T dx = xy[0] - T(r.anchor.x()), dy = xy[1] - T(r.anchor.y()), dz = z[0] - T(r.anchor.z());
    residual[0] = (ceres::sqrt(dx * dx + dy * dy + dz * dz + T(1e-18)) - T(r.range_m)) / T(r.sigma_m);
    return true;
  }
};

constexpr const char* kCoplanarWhy =
    "the anchors are in one plane: above and below it cannot be told apart (give the tag's height or a z range)";

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

}  // namespace

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

namespace {

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

}  // namespace

namespace {

// One weighted least-squares solve from `start` (Cauchy loss at robust_sigmas when > 0).
RangeFix solve_least_squares(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options,
                             const Eigen::Vector3d& start) {
  RangeFix fix;
  double xy[2] = {start.x(), start.y()};
  double z[1] = {start.z()};
  ceres::Problem problem;
  for (const auto& r : ranges) {
    ceres::LossFunction* loss = options.robust_sigmas > 0 ? new ceres::CauchyLoss(options.robust_sigmas) : nullptr;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RangeResidual, 1, 2, 1>(new RangeResidual{r}), loss, xy,
                             z);
  }
  if (options.known_height) {
    problem.SetParameterBlockConstant(z);
  } else if (options.z_range) {
    problem.SetParameterLowerBound(z, 0, options.z_range->first);
    problem.SetParameterUpperBound(z, 0, options.z_range->second);
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 50;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    fix.why = "the least-squares solve failed: " + summary.message;
    return fix;
  }
  fix.position = {xy[0], xy[1], z[0]};
  if (!fix.position.allFinite()) {
    fix.why = "the least-squares solve diverged";
    return fix;
  }
  return finish(std::move(fix), ranges, options);
}

// Sum of squared residuals in sigmas, and the largest one.
std::pair<double, double> normalised_residuals(std::span<const RangeToAnchor> ranges, const Eigen::Vector3d& p) {
  double sum = 0, worst = 0;
  for (const auto& r : ranges) {
    const double e = std::abs((r.anchor - p).norm() - r.range_m) / r.sigma_m;
    sum += e * e;
    worst = std::max(worst, e);
  }
  return {sum, worst};
}

}  // namespace

RangeFix fix_least_squares(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options,
                           const std::optional<Eigen::Vector3d>& initial) {
  RangeFix fix;
  if (!check_input(ranges, options, fix)) return fix;
  fix = solve_least_squares(ranges, options, starting_point(ranges, options, initial));
  if (!fix.ok || !(options.robust_sigmas > 0) || !(options.reject_sigmas > 0)) return fix;
  // A range the others contradict (non-line-of-sight: a reflection, a body in the way) pulls
  // even a robust loss where the geometry is weak. While some range is off by more than
  // reject_sigmas and enough remain to check the rest (two more than the unknowns), the range
  // whose removal leaves the most consistent set is left out.
  const std::size_t unknowns = options.known_height ? 2 : 3;
  std::vector<RangeToAnchor> used(ranges.begin(), ranges.end());
  while (used.size() >= unknowns + 3 && normalised_residuals(used, fix.position).second > options.reject_sigmas) {
    RangeFix best;
    std::size_t best_i = 0;
    double best_cost = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < used.size(); ++i) {
      std::vector<RangeToAnchor> rest = used;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
      // From where the contradicted solve ended and afresh from the rest's subsets: the first
      // may sit in a wrong valley the bad range dug (a near-mirror of the true position).
      for (const Eigen::Vector3d& start : {fix.position, starting_point(rest, options, std::nullopt)}) {
        RangeFix f = solve_least_squares(rest, options, start);
        if (!f.ok) continue;
        const double cost = normalised_residuals(rest, f.position).first;
        if (cost < best_cost) best_cost = cost, best = std::move(f), best_i = i;
      }
    }
    if (!best.ok) break;
    used.erase(used.begin() + static_cast<std::ptrdiff_t>(best_i));
    const int rejected = fix.ranges_rejected + 1;
    fix = std::move(best);
    fix.ranges_rejected = rejected;
  }
  return fix;
}

RangeFix fix_nelder_mead(std::span<const RangeToAnchor> ranges, const RangeSolveOptions& options,
                         const std::optional<Eigen::Vector3d>& initial) {
  RangeFix fix;
  if (!check_input(ranges, options, fix)) return fix;
  const Eigen::Vector3d start = starting_point(ranges, options, initial);
  struct Problem {
    std::span<const RangeToAnchor> ranges;
    std::optional<double> z;
  } problem{ranges, options.known_height};
  // Petković et al.'s eq. (5): F = sum_i (|p_i - p| - d_i)^2, unweighted.
  const auto objective = [](unsigned, const double* x, double*, void* data) {
    const auto* pb = static_cast<const Problem*>(data);
    const Eigen::Vector3d p(x[0], x[1], pb->z ? *pb->z : x[2]);
    double f = 0;
    for (const auto& r : pb->ranges) f += std::pow((r.anchor - p).norm() - r.range_m, 2);
    return f;
  };
  const unsigned dim = options.known_height ? 2 : 3;
  nlopt::opt opt(nlopt::LN_NELDERMEAD, dim);
  opt.set_min_objective(objective, &problem);
  opt.set_xtol_abs(1e-7);
  opt.set_maxeval(5000);
  opt.set_initial_step(0.1);
  if (options.z_range && !options.known_height) {
    const double inf = std::numeric_limits<double>::infinity();
    opt.set_lower_bounds(std::vector<double>{-inf, -inf, options.z_range->first});
    opt.set_upper_bounds(std::vector<double>{inf, inf, options.z_range->second});
  }
  std::vector<double> x = {start.x(), start.y()};
  if (dim == 3) x.push_back(start.z());
  double f = 0;
  try {
    opt.optimize(x, f);
  } catch (const std::exception& e) {
    fix.why = std::string("Nelder-Mead failed: ") + e.what();
    return fix;
  }
  fix.position = {x[0], x[1], dim == 3 ? x[2] : *options.known_height};
  if (!fix.position.allFinite()) {
    fix.why = "Nelder-Mead diverged";
    return fix;
  }
  return finish(std::move(fix), ranges, options);
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
