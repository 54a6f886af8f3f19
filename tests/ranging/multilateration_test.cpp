// The range solvers against hand-computed positions and covariances, the simulator setups of the
// two papers they come from, and bad input.
#include "ips/ranging/multilateration.h"

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "release_only.h"

namespace ips {
namespace {

std::vector<RangeToAnchor> exact_ranges(const std::vector<Eigen::Vector3d>& anchors, const Eigen::Vector3d& tag,
                                        double sigma = 0.1) {
  std::vector<RangeToAnchor> out;
  for (const auto& a : anchors) out.push_back({a, (a - tag).norm(), sigma});
  return out;
}

TEST(Multilateration, FourRangesSolveToTheHandComputedPoint) {
  // Tag (1, 1, 1): ranges sqrt(3) to the origin and sqrt(11) to (4,0,0), (0,4,0), (0,0,4).
  const std::vector<RangeToAnchor> four = {{{0, 0, 0}, std::sqrt(3.0)},
                                           {{4, 0, 0}, std::sqrt(11.0)},
                                           {{0, 4, 0}, std::sqrt(11.0)},
                                           {{0, 0, 4}, std::sqrt(11.0)}};
  const auto p = solve_four_ranges(four);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->x(), 1.0, 1e-12);
  EXPECT_NEAR(p->y(), 1.0, 1e-12);
  EXPECT_NEAR(p->z(), 1.0, 1e-12);
}

TEST(Multilateration, CoplanarAnchorsNeedTheTagsHeight) {
  // Four anchors on a 2.5 m high ceiling plane, a tag at 1.3 m: every 4-subset is coplanar.
  const std::vector<Eigen::Vector3d> anchors = {{0, 0, 2.5}, {6, 0, 2.5}, {6, 4, 2.5}, {0, 4, 2.5}};
  const Eigen::Vector3d tag(2.0, 1.5, 1.3);
  const auto ranges = exact_ranges(anchors, tag);
  EXPECT_FALSE(solve_four_ranges(ranges).has_value());
  const RangeFix unsolvable = fix_from_subsets(ranges, SubsetVote::kMedian);
  EXPECT_FALSE(unsolvable.ok);
  EXPECT_NE(unsolvable.why.find("one plane"), std::string::npos) << unsolvable.why;
  RangeSolveOptions at_height;
  at_height.known_height = 1.3;
  const RangeFix fix = fix_from_subsets(ranges, SubsetVote::kMedian, at_height);
  ASSERT_TRUE(fix.ok) << fix.why;
  EXPECT_EQ(fix.subsets_solved, 4);
  EXPECT_LT((fix.position - tag).norm(), 1e-9);
  EXPECT_EQ(fix.covariance(2, 2), 0.0);
  const RangeFix ls = fix_least_squares(ranges, at_height);
  ASSERT_TRUE(ls.ok) << ls.why;
  EXPECT_LT((ls.position - tag).norm(), 1e-6);
}

TEST(Multilateration, CoplanarAnchorsAndAZoneRangeOnOneSideSolveIn3DNeverTheMirror) {
  const std::vector<Eigen::Vector3d> anchors = {{0, 0, 2.5}, {6, 0, 2.5}, {6, 4, 2.5}, {0, 4, 2.5}, {3, -1, 2.5}};
  const Eigen::Vector3d tag(2.0, 1.5, 1.3);
  const auto ranges = exact_ranges(anchors, tag);
  // Started on the tag's side, plain least squares would converge: refused all the same.
  const RangeFix refused = fix_least_squares(ranges, {}, Eigen::Vector3d(2, 1, 1));
  EXPECT_FALSE(refused.ok);
  EXPECT_EQ(refused.status, RangeFixStatus::kCoplanar);
  EXPECT_STREQ(range_fix_status_word(refused.status), "coplanar");
  RangeSolveOptions below;
  below.z_range = std::make_pair(0.0, 2.4);
  for (const RangeFix& fix : {fix_least_squares(ranges, below), fix_nelder_mead(ranges, below)}) {
    ASSERT_TRUE(fix.ok) << fix.why;
    EXPECT_LT((fix.position - tag).norm(), 1e-4) << fix.position.transpose();
  }
}

TEST(Multilateration, LeastSquaresCovarianceIsTheHandComputedOne) {
  // Six anchors 5 m from the tag along +-x, +-y, +-z, sigma 0.1 m: J^T W J = 2 / sigma^2 I, so
  // the covariance is sigma^2 / 2 = 0.005 m^2 on each axis and nothing across.
  const Eigen::Vector3d tag(1.0, 2.0, 1.5);
  std::vector<Eigen::Vector3d> anchors;
  for (int axis = 0; axis < 3; ++axis)
    for (double sign : {-1.0, 1.0}) anchors.push_back(tag + sign * 5.0 * Eigen::Vector3d::Unit(axis));
  const RangeFix fix = fix_least_squares(exact_ranges(anchors, tag), {}, Eigen::Vector3d(0, 0, 0));
  ASSERT_TRUE(fix.ok) << fix.why;
  EXPECT_LT((fix.position - tag).norm(), 1e-6);
  EXPECT_LT(fix.rms_residual_m, 1e-6);
  EXPECT_EQ(fix.ranges_used, 6);
  EXPECT_TRUE(fix.covariance.isApprox(0.005 * Eigen::Matrix3d::Identity(), 1e-6)) << fix.covariance;
}

// Petković et al. (2016), their simulation: four devices at the corners of a rectangle, the
// beacon at 1.3 m, range errors Gaussian within +-10 cm; "mostly below 5 cm", worst "almost
// 20 cm". The devices' height and the room are not given: 2.5 m and 6 x 4 m here, the beacon's
// height known (the devices are coplanar).
TEST(Multilateration, PetkovicSimulationErrorsAsPublished) {
  const std::vector<Eigen::Vector3d> anchors = {{0, 0, 2.5}, {6, 0, 2.5}, {6, 4, 2.5}, {0, 4, 2.5}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(0.3, 5.7), uy(0.3, 3.7);
  std::normal_distribution<double> noise(0.0, 0.1 / 3);  // 3 sigma at 10 cm, truncated there
  RangeSolveOptions options;
  options.known_height = 1.3;
  options.robust_sigmas = 0;  // plain least squares, as the paper
  std::vector<double> errors;
  double nees = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const Eigen::Vector3d tag(ux(rng), uy(rng), 1.3);
    auto ranges = exact_ranges(anchors, tag, 0.1 / 3);
    for (auto& r : ranges) r.range_m += std::clamp(noise(rng), -0.1, 0.1);
    const RangeFix fix = fix_least_squares(ranges, options);
    ASSERT_TRUE(fix.ok) << fix.why;
    // Petković's own minimiser (Nelder-Mead on the same F) finds the same minimum.
    const RangeFix nm = fix_nelder_mead(ranges, options);
    ASSERT_TRUE(nm.ok) << nm.why;
    EXPECT_LT((nm.position - fix.position).norm(), 1e-3);
    const Eigen::Vector2d e = (fix.position - tag).head<2>();
    errors.push_back(e.norm());
    nees += e.dot(fix.covariance.topLeftCorner<2, 2>().inverse() * e);
  }
  std::sort(errors.begin(), errors.end());
  const double below_5cm =
      double(std::lower_bound(errors.begin(), errors.end(), 0.05) - errors.begin()) / double(errors.size());
  std::printf("Petkovic setup: median %.1f cm, p95 %.1f cm, worst %.1f cm, %.0f %% below 5 cm, NEES %.2f\n",
              100 * errors[500], 100 * errors[950], 100 * errors.back(), 100 * below_5cm, nees / 1000);
  EXPECT_GT(below_5cm, 0.5);  // "mostly below 5 cm"
  EXPECT_LT(errors.back(), 0.20);
  // The covariance describes the errors: the mean normalised squared error of a 2-D estimate is
  // 2 when it does (a little less here: the noise is truncated at 3 sigma).
  EXPECT_NEAR(nees / 1000, 2.0, 0.3);
}

// Petković et al.'s static test, in simulation: a beacon that does not move, fixed again and
// again from fresh Gaussian ranges. An efficient estimator's spread is the Cramér-Rao bound,
// computed here by hand from the geometry: (sum_i u_i u_i^T / sigma^2)^-1, u_i the horizontal
// part of the unit vector from anchor i to the beacon (the height is known).
TEST(Multilateration, StaticSpreadIsTheCramerRaoBound) {
  const std::vector<Eigen::Vector3d> anchors = {{0, 0, 2.5}, {6, 0, 2.5}, {6, 4, 2.5}, {0, 4, 2.5}};
  const Eigen::Vector3d tag(2.0, 1.2, 1.3);
  const double sigma = 0.1 / 3;
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
  for (const auto& a : anchors) {
    const Eigen::Vector2d u = (tag - a).head<2>() / (tag - a).norm();
    information += u * u.transpose() / (sigma * sigma);
  }
  const Eigen::Matrix2d crb = information.inverse();
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, sigma);
  RangeSolveOptions options;
  options.known_height = 1.3;
  options.robust_sigmas = 0;
  const int n = 2000;
  std::vector<Eigen::Vector2d> fixes;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int k = 0; k < n; ++k) {
    auto ranges = exact_ranges(anchors, tag, sigma);
    for (auto& r : ranges) r.range_m += noise(rng);
    const RangeFix fix = fix_least_squares(ranges, options);
    ASSERT_TRUE(fix.ok) << fix.why;
    fixes.push_back(fix.position.head<2>());
    mean += fixes.back() / n;
  }
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  for (const auto& f : fixes) spread += (f - mean) * (f - mean).transpose() / (n - 1);
  const double ratio = std::sqrt(spread.trace() / crb.trace());
  std::printf("static beacon: spread %.2f cm rms, Cramer-Rao bound %.2f cm, ratio %.3f, bias %.2f mm\n",
              100 * std::sqrt(spread.trace()), 100 * std::sqrt(crb.trace()), ratio,
              1e3 * (mean - tag.head<2>()).norm());
  EXPECT_LT(ratio, 1.1);   // the bound
  EXPECT_GT(ratio, 0.95);  // below the bound would mean the test's noise is not what it says
  EXPECT_LT((mean - tag.head<2>()).norm(), 0.002);
}

// Albayati & Kurt (2019), Table 1: with more references than four, every 4-subset solved and
// the per-axis median taken beats the mean, and improves with more references. Here one range
// of every fix is non-line-of-sight (+0.5 m), the others have 2 cm of noise.
TEST(Multilateration, SubsetMedianBeatsTheMeanAndImprovesWithMoreReferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> room(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.02);
  const auto mean_error = [&](int references, SubsetVote vote) {
    std::mt19937 local(rng());
    double sum = 0;
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<Eigen::Vector3d> anchors;
      for (int i = 0; i < references; ++i)
        anchors.push_back({8 * room(local), 6 * room(local), 0.5 + 2.5 * room(local)});
      const Eigen::Vector3d tag(2 + 4 * room(local), 1.5 + 3 * room(local), 1.0);
      auto ranges = exact_ranges(anchors, tag, 0.02);
      for (auto& r : ranges) r.range_m += noise(local);
      ranges[0].range_m += 0.5;
      const RangeFix fix = fix_from_subsets(ranges, vote);
      EXPECT_TRUE(fix.ok) << fix.why;
      sum += (fix.position - tag).norm();
    }
    return sum / 200;
  };
  const double median5 = mean_error(5, SubsetVote::kMedian), mean5 = mean_error(5, SubsetVote::kMean);
  const double median8 = mean_error(8, SubsetVote::kMedian), mean8 = mean_error(8, SubsetVote::kMean);
  std::printf("subset vote, mean error: 5 references median %.1f cm mean %.1f cm; 8 median %.1f cm mean %.1f cm\n",
              100 * median5, 100 * mean5, 100 * median8, 100 * mean8);
  EXPECT_LT(median5, mean5);
  EXPECT_LT(median8, mean8);
  EXPECT_LT(median8, median5);
}

TEST(Multilateration, BadRangesAreNamedNotSolved) {
  const std::vector<Eigen::Vector3d> anchors = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 0, 4}, {4, 4, 4}};
  auto ranges = exact_ranges(anchors, {1, 1, 1});
  ranges[2].range_m = std::nan("");
  for (const RangeFix& fix : {fix_from_subsets(ranges, SubsetVote::kMedian), fix_least_squares(ranges)}) {
    EXPECT_FALSE(fix.ok);
    EXPECT_NE(fix.why.find("range 2"), std::string::npos) << fix.why;
  }
  ranges[2].range_m = 3;
  ranges[4].sigma_m = 0;
  EXPECT_NE(fix_least_squares(ranges).why.find("range 4"), std::string::npos);
  const RangeFix few = fix_least_squares(std::span(ranges).first(3));
  EXPECT_FALSE(few.ok);
  EXPECT_EQ(few.status, RangeFixStatus::kTooFew);
  EXPECT_NE(few.why.find("at least 4"), std::string::npos) << few.why;
}

}  // namespace
}  // namespace ips

namespace ips {
namespace {

// Albayati & Kurt's protocol rebuilt: a robot at 1 m ranges to 4 fixed references at the corners
// of an 8 x 6 m room at 2.8, 0.4, 2.2 and 1.2 m and to 3 assisting robots (mobile references,
// beacons at 0.3 m) somewhere on the floor; 2000 fixes. The default estimator (robust least
// squares) against the paper's own per-axis median of the 4-subsets, on the same ranges.
struct Percentiles {
  double p50, p95;
};
Percentiles percentiles(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return {v[v.size() / 2], v[static_cast<std::size_t>(0.95 * static_cast<double>(v.size()))]};
}

TEST(Multilateration, TheDefaultEstimatorBeatsTheFaithfulMedianOfSubsets) {
  const auto compare = [](double sigma, double nlos, const char* name,
                          int robots = 3) -> std::pair<Percentiles, Percentiles> {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::vector<double> robust, median4;
    // The figures in docs/ranging.md are the release build's 2000 fixes; under the sanitizers
    // (ten times slower) 500 check the same ratios.
    const int fixes = test::kSanitized ? 500 : 2000;
    for (int trial = 0; trial < fixes; ++trial) {
      std::vector<Eigen::Vector3d> refs = {{0, 0, 2.8}, {8, 0, 0.4}, {8, 6, 2.2}, {0, 6, 1.2}};
      for (int k = 0; k < robots; ++k) refs.push_back({8 * u(rng), 6 * u(rng), 0.3});
      const Eigen::Vector3d tag(1 + 6 * u(rng), 1 + 4 * u(rng), 1.0);
      auto ranges = exact_ranges(refs, tag, std::max(sigma, 0.01));
      for (auto& r : ranges) r.range_m += sigma * noise(rng);
      if (nlos > 0) ranges[static_cast<std::size_t>(trial) % ranges.size()].range_m += nlos;
      const RangeFix a = fix_least_squares(ranges), b = fix_from_subsets(ranges, SubsetVote::kMedian);
      if (!a.ok || !b.ok) {
        ADD_FAILURE() << name << ", fix " << trial << ": " << a.why << b.why;
        continue;
      }
      robust.push_back((a.position - tag).norm());
      median4.push_back((b.position - tag).norm());
    }
    const Percentiles r = percentiles(robust), m = percentiles(median4);
    std::printf(
        "Albayati & Kurt's protocol, %d robots, %s: default p50 %.2f p95 %.2f cm; median4 p50 %.2f p95 %.2f cm\n",
        robots, name, 100 * r.p50, 100 * r.p95, 100 * m.p50, 100 * m.p95);
    return std::pair{r, m};
  };
  const auto [exact_r, exact_m] = compare(0.0, 0.0, "exact ranges");
  EXPECT_LT(exact_r.p95, 1e-6);
  EXPECT_LT(exact_m.p95, 1e-6);
  const auto [noisy_r, noisy_m] = compare(0.02, 0.0, "2 cm ranges");
  EXPECT_LE(noisy_r.p50, 0.75 * noisy_m.p50);
  EXPECT_LE(noisy_r.p95, 0.75 * noisy_m.p95);
  const auto [nlos_r, nlos_m] = compare(0.02, 0.5, "2 cm ranges, one +0.5 m");
  EXPECT_LE(nlos_r.p50, 0.5 * nlos_m.p50);
  EXPECT_LE(nlos_r.p95, 0.5 * nlos_m.p95);
  // Two assisting robots: the least redundancy at which a range is left out (6 ranges, 3
  // unknowns), where a bad range can hide unless every candidate is tried from two starts.
  // (Their 2 cm p50 ratio is 0.75, at the limit: not asserted.)
  const auto [two_r, two_m] = compare(0.02, 0.5, "2 cm ranges, one +0.5 m", 2);
  EXPECT_LE(two_r.p50, 0.5 * two_m.p50);
  EXPECT_LE(two_r.p95, 0.5 * two_m.p95);
}

}  // namespace
}  // namespace ips
