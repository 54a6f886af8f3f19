// Positions from ranges by iteration: weighted least squares (Ceres; robust by default: a
// Cauchy loss and contradicted ranges left out) and Petković et al.'s Nelder-Mead (NLopt).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <ceres/ceres.h>
#include <nlopt.hpp>

#include "ips/ranging/multilateration.h"
#include "ranging/solver_common.h"

namespace ips {

using ranging_detail::check_input;
using ranging_detail::finish;
using ranging_detail::starting_point;

namespace {

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
    // Fast path, where the rest is redundant enough (three more ranges than unknowns) that a
    // bad range cannot hide in it: the range with the largest residual, left out, and the rest
    // fits. With less redundancy it can (measured: p95 100 cm instead of 16 cm), so every
    // candidate is tried.
    const bool fast = used.size() >= unknowns + 4;
    std::size_t suspect = 0;
    double largest = -1;
    for (std::size_t i = 0; i < used.size(); ++i) {
      const double e = std::abs((used[i].anchor - fix.position).norm() - used[i].range_m) / used[i].sigma_m;
      if (e > largest) largest = e, suspect = i;
    }
    if (fast) {
      std::vector<RangeToAnchor> rest = used;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(suspect));
      RangeFix f = solve_least_squares(rest, options, fix.position);
      if (f.ok && normalised_residuals(rest, f.position).second <= options.reject_sigmas) {
        best = std::move(f);
        best_i = suspect;
      }
    }
    const bool found_fast = best.ok;
    for (std::size_t i = 0; !found_fast && i < used.size(); ++i) {
      std::vector<RangeToAnchor> rest = used;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
      // From where the contradicted solve ended and afresh from the rest's own subsets: the bad
      // range may have dug a wrong valley (a near-mirror position) that the rest fits as well.
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

}  // namespace ips
