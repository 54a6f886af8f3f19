// The range tracker against exact truth: a static tag and exact ranges, a tag on a circle with
// noisy ranges taken one at a time (as UWB modules range), an anchor that reads long, and
// non-line-of-sight ranges the gate must leave out; and the ranges it must refuse.
#include "ips/ranging/range_tracker.h"

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace ips {
namespace {

// Four anchors at different heights at the corners of a 6 x 4 m room.
const std::vector<Eigen::Vector3d> kAnchors = {{0, 0, 2.5}, {6, 0, 1.2}, {6, 4, 2.2}, {0, 4, 0.6}};
constexpr std::int64_t kMs = 1'000'000;

TEST(RangeTracker, StaticTagWithExactRangesConvergesToTheTruth) {
  const Eigen::Vector3d tag(2.0, 1.5, 1.0);
  RangeTracker tracker(kAnchors, {});
  EXPECT_FALSE(tracker.state());
  // One range every 10 ms, round robin: the first three only wait for the fourth.
  for (std::size_t i = 0; i < 400; ++i) {
    const std::size_t a = i % kAnchors.size();
    const RangeUpdate u =
        tracker.add_anchor_range(static_cast<std::int64_t>(i) * 10 * kMs, a, (kAnchors[a] - tag).norm(), 0.05);
    const RangeUpdate expected = i < 3    ? RangeUpdate::kInitialising
                                 : i == 3 ? RangeUpdate::kStarted
                                          : RangeUpdate::kAccepted;
    EXPECT_EQ(u, expected) << i;
  }
  const auto s = tracker.state();
  ASSERT_TRUE(s);
  EXPECT_LT((s->position - tag).norm(), 1e-6);
  EXPECT_LT(s->velocity.norm(), 1e-6);
  for (double b : tracker.biases()) EXPECT_NEAR(b, 0.0, 1e-6);
  EXPECT_EQ(tracker.rejected(), 0u);
}

// A tag on a circle (r 0.8 m, 0.4 m/s, 0.3 m up) ranging to one anchor every 10 ms.
Eigen::Vector3d circle(double t) {
  const double w = 0.4 / 0.8;
  return {3.0 + 0.8 * std::cos(w * t), 2.0 + 0.8 * std::sin(w * t), 0.3};
}

struct CircleRun {
  std::vector<double> errors_2d;    // after the first 5 s
  std::vector<double> snapshot_2d;  // least squares over the latest range to each anchor, same instants
  std::vector<double> biases;
  std::uint64_t rejected = 0;
  double mean_nees = 0;  // mean normalised squared 2-D error: 2 when the covariance is right
};

// odometry_sigma > 0: every fourth range (a firing of 40 ms) also gives the distance travelled
// since the previous one with this 1-sigma, as a speed.
CircleRun run_circle(const RangeTrackerOptions& options, double sigma, double anchor2_bias, double nlos_fraction,
                     unsigned seed, double odometry_sigma = 0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  RangeTracker tracker(kAnchors, options);
  CircleRun run;
  double nees = 0;
  std::vector<RangeToAnchor> latest(kAnchors.size());
  RangeSolveOptions plain;
  plain.known_height = options.known_height;
  plain.robust_sigmas = 0;
  plain.reject_sigmas = 0;
  for (int i = 0; i < 6000; ++i) {  // 60 s
    const double t = 0.01 * i;
    const std::size_t a = static_cast<std::size_t>(i) % kAnchors.size();
    double range = (kAnchors[a] - circle(t)).norm() + noise(rng);
    if (a == 2) range += anchor2_bias;
    if (u01(rng) < nlos_fraction) range += 0.3 + 0.5 * u01(rng);  // a reflection: always long
    tracker.add_anchor_range(static_cast<std::int64_t>(i) * 10 * kMs, a, range, sigma);
    if (odometry_sigma > 0 && a == kAnchors.size() - 1) {
      // Noise drawn from its own stream: the ranges stay those of the run without odometry.
      static std::mt19937 odometry_rng;
      if (i == 3) odometry_rng.seed(seed + 100);
      const double travelled = 0.4 * 0.04 + std::normal_distribution<double>(0.0, odometry_sigma)(odometry_rng);
      tracker.add_speed(static_cast<std::int64_t>(i) * 10 * kMs, travelled / 0.04, odometry_sigma / 0.04);
    }
    latest[a] = {kAnchors[a], range, sigma};
    const auto s = tracker.state();
    if (t > 5.0 && s) {
      const Eigen::Vector2d e = (s->position - circle(t)).head<2>();
      run.errors_2d.push_back(e.norm());
      nees += e.dot(s->covariance.topLeftCorner<2, 2>().inverse() * e);
      const RangeFix fix = fix_least_squares(latest, plain);
      if (fix.ok) run.snapshot_2d.push_back((fix.position - circle(t)).head<2>().norm());
    }
  }
  run.mean_nees = nees / static_cast<double>(std::max<std::size_t>(1, run.errors_2d.size()));
  run.biases = tracker.biases();
  run.rejected = tracker.rejected();
  return run;
}

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(0.95 * double(v.size() - 1))];
}

TEST(RangeTracker, FollowsACircleFromRangesTakenOneAtATime) {
  RangeTrackerOptions options;
  options.known_height = 0.3;
  const CircleRun run = run_circle(options, 0.02, 0.0, 0.0, 1);
  ASSERT_GT(run.errors_2d.size(), 5000u);
  std::printf(
      "circle, 2 cm ranges: p95 2-D %.1f mm (mean NEES %.2f), %llu rejected; the latest four ranges solved "
      "together: p95 %.1f mm\n",
      1e3 * p95(run.errors_2d), run.mean_nees, static_cast<unsigned long long>(run.rejected),
      1e3 * p95(run.snapshot_2d));
  // The filter uses every range, not four: inside the snapshot's error (measured 28.4 against
  // 43.1 mm: this geometry's horizontal precision is poor, anchors 0.3-2.2 m above the tag),
  // and its stated covariance is right (a mean NEES of 2 for a 2-D error; below, on the safe side).
  EXPECT_LT(p95(run.errors_2d), 0.8 * p95(run.snapshot_2d));
  EXPECT_GT(run.mean_nees, 1.0);
  EXPECT_LT(run.mean_nees, 3.0);
  EXPECT_LT(run.rejected, 60u);  // a 4-sigma gate leaves out ~0.006 % of Gaussian ranges; allow for the start
}

TEST(RangeTracker, LearnsTheBiasOfAnAnchorThatReadsLong) {
  RangeTrackerOptions options;
  options.known_height = 0.3;
  options.bias_learning = RangeTrackerOptions::BiasLearning::kOn;  // 4 anchors: kAuto would wait for the cameras
  const CircleRun learnt = run_circle(options, 0.02, 0.10, 0.0, 2);
  options.bias_learning = RangeTrackerOptions::BiasLearning::kOff;
  const CircleRun ignored = run_circle(options, 0.02, 0.10, 0.0, 2);
  std::printf(
      "anchor 2 reads 10 cm long: bias learnt %.1f mm (others %.1f %.1f %.1f); p95 2-D %.1f mm, %.1f mm "
      "without the bias states\n",
      1e3 * learnt.biases[2], 1e3 * learnt.biases[0], 1e3 * learnt.biases[1], 1e3 * learnt.biases[3],
      1e3 * p95(learnt.errors_2d), 1e3 * p95(ignored.errors_2d));
  EXPECT_NEAR(learnt.biases[2], 0.10, 0.02);
  for (int k : {0, 1, 3}) EXPECT_NEAR(learnt.biases[static_cast<std::size_t>(k)], 0.0, 0.02) << k;
  EXPECT_LT(p95(learnt.errors_2d), 0.05);
  EXPECT_GT(p95(ignored.errors_2d), 2 * p95(learnt.errors_2d));
}

TEST(RangeTracker, OdometrySpeedTightensTheTrack) {
  // The same circle and ranges, with and without wheel odometry (distance per 40 ms firing,
  // 1 mm 1-sigma: 2 % of 0.4 m/s * 40 ms, plus a little).
  RangeTrackerOptions options;
  options.known_height = 0.3;
  const CircleRun ranges_only = run_circle(options, 0.05, 0.0, 0.0, 7);
  const CircleRun with_odometry = run_circle(options, 0.05, 0.0, 0.0, 7, 0.001);
  std::printf("circle, 5 cm ranges: p95 2-D %.1f mm with odometry (mean NEES %.2f), %.1f mm without\n",
              1e3 * p95(with_odometry.errors_2d), with_odometry.mean_nees, 1e3 * p95(ranges_only.errors_2d));
  EXPECT_LT(p95(with_odometry.errors_2d), 0.9 * p95(ranges_only.errors_2d));
  EXPECT_LT(with_odometry.mean_nees, 3.0);
}

TEST(RangeTracker, ZeroOdometryHoldsAStandingTagStill) {
  // A parked robot: 5 cm ranges at 100 Hz; its wheels say it has not moved (0 +- 1 mm per 40 ms).
  RangeTrackerOptions options;
  options.known_height = 1.0;
  const Eigen::Vector3d tag(2.0, 1.5, 1.0);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  RangeTracker plain(kAnchors, options), still(kAnchors, options);
  std::vector<double> plain_error, still_error;
  std::uint64_t unused = 0;
  for (int i = 0; i < 3000; ++i) {
    const std::int64_t t = static_cast<std::int64_t>(i) * 10 * kMs;
    const std::size_t a = static_cast<std::size_t>(i) % kAnchors.size();
    const double range = (kAnchors[a] - tag).norm() + noise(rng);
    plain.add_anchor_range(t, a, range, 0.05);
    still.add_anchor_range(t, a, range, 0.05);
    if (a == 3 && still.add_speed(t, 0.0, 0.001 / 0.04) == RangeUpdate::kUnused) ++unused;
    if (i > 500) {
      plain_error.push_back((plain.state()->position - tag).head<2>().norm());
      still_error.push_back((still.state()->position - tag).head<2>().norm());
    }
  }
  std::printf("standing tag, 5 cm ranges: p95 2-D %.1f mm with zero odometry, %.1f mm without\n",
              1e3 * p95(still_error), 1e3 * p95(plain_error));
  EXPECT_EQ(unused, 0u);  // the first firing's speed comes after its track has started (4th range)
  EXPECT_GT(still.speeds(), 700u);
  EXPECT_LT(p95(still_error), 0.6 * p95(plain_error));
  EXPECT_LT(still.state()->velocity.norm(), 1e-3);
}

TEST(RangeTracker, ASpeedNeitherStartsNorDirectsATrack) {
  RangeTrackerOptions options;
  options.known_height = 1.0;
  RangeTracker tracker(kAnchors, options);
  EXPECT_EQ(tracker.add_speed(0, 0.3, 0.01), RangeUpdate::kUnused);  // no track yet
  EXPECT_EQ(tracker.add_speed(0, -0.1, 0.01), RangeUpdate::kInvalid);
  EXPECT_EQ(tracker.add_speed(0, 0.1, 0.0), RangeUpdate::kInvalid);
  const Eigen::Vector3d tag(2.0, 1.5, 1.0);
  for (std::size_t a = 0; a < kAnchors.size(); ++a)
    tracker.add_anchor_range(static_cast<std::int64_t>(a) * 10 * kMs, a, (kAnchors[a] - tag).norm(), 0.02);
  ASSERT_TRUE(tracker.started());
  // Started at rest (velocity 0): a moving speed has no direction to be applied along.
  EXPECT_EQ(tracker.add_speed(40 * kMs, 0.3, 0.01), RangeUpdate::kUnused);
  EXPECT_EQ(tracker.add_speed(50 * kMs, 0.0, 0.01), RangeUpdate::kAccepted);
  // Seconds later a speed neither restarts the track nor keeps it alive.
  EXPECT_EQ(tracker.add_speed(5000 * kMs, 0.0, 0.01), RangeUpdate::kUnused);
  EXPECT_TRUE(tracker.started());
  EXPECT_EQ(tracker.restarts(), 0u);
  EXPECT_STREQ(range_update_word(RangeUpdate::kUnused), "unused");
}

TEST(RangeTracker, TheGateLeavesOutNonLineOfSightRanges) {
  RangeTrackerOptions options;
  options.known_height = 0.3;
  const CircleRun gated = run_circle(options, 0.02, 0.0, 0.05, 3);
  options.gate_sigmas = 0;
  const CircleRun ungated = run_circle(options, 0.02, 0.0, 0.05, 3);
  std::printf("5 %% of ranges 0.3-0.8 m long: p95 2-D %.1f mm gated (%llu left out), %.1f mm without the gate\n",
              1e3 * p95(gated.errors_2d), static_cast<unsigned long long>(gated.rejected),
              1e3 * p95(ungated.errors_2d));
  // ~300 of the 6000 are long; the gate leaves out (nearly) all of them.
  EXPECT_GT(gated.rejected, 250u);
  EXPECT_LT(gated.rejected, 400u);
  EXPECT_LT(p95(gated.errors_2d), 0.05);
  EXPECT_GT(p95(ungated.errors_2d), 2 * p95(gated.errors_2d));
}

TEST(RangeTracker, ALateRangeIsAppliedInItsPlace) {
  // The circle's ranges delivered 0-300 ms late in random order (a radio that bursts, a
  // bridge that batches): every one within the 0.5 s reorder window is applied in its place,
  // so the track ends exactly where the in-order track does.
  RangeTrackerOptions options;
  options.known_height = 0.3;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::uniform_real_distribution<double> delay(0.0, 0.3);
  struct Range {
    std::int64_t t_ns;
    std::size_t anchor;
    double range, arrival;
  };
  std::vector<Range> ranges;
  for (int i = 0; i < 3000; ++i) {
    const double t = 0.01 * i;
    const std::size_t a = static_cast<std::size_t>(i) % kAnchors.size();
    ranges.push_back({static_cast<std::int64_t>(i) * 10 * kMs, a, (kAnchors[a] - circle(t)).norm() + noise(rng),
                      t + (i < 8 ? 0.0 : delay(rng))});
  }
  RangeTracker in_order(kAnchors, options), late(kAnchors, options);
  for (const Range& r : ranges) in_order.add_anchor_range(r.t_ns, r.anchor, r.range, 0.02);
  std::vector<Range> arrivals = ranges;
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const Range& a, const Range& b) { return a.arrival < b.arrival; });
  int out_of_order = 0;
  for (const Range& r : arrivals)
    if (late.add_anchor_range(r.t_ns, r.anchor, r.range, 0.02) == RangeUpdate::kOutOfOrder) ++out_of_order;
  EXPECT_EQ(out_of_order, 0);
  EXPECT_GT(late.replayed(), 1000u);
  EXPECT_EQ(late.accepted(), in_order.accepted());
  const auto a = in_order.state(), b = late.state();
  ASSERT_TRUE(a && b);
  EXPECT_LT((a->position - b->position).norm(), 1e-9);
  // The state at a past instant is the one the ranges up to it gave (within the window).
  const std::int64_t past = ranges.back().t_ns - 200 * kMs;
  const auto at = late.state_at(past);
  ASSERT_TRUE(at);
  EXPECT_EQ(at->t_ns, past);
  EXPECT_LT((at->position - circle(1e-9 * static_cast<double>(past))).head<2>().norm(), 0.06);
  EXPECT_FALSE(late.state_at(ranges.back().t_ns - 2000 * kMs));  // before the window
}

TEST(RangeTracker, RefusesWhatItCannotUse) {
  RangeTracker tracker(kAnchors, {});
  EXPECT_EQ(tracker.add_anchor_range(0, 4, 1.0, 0.05), RangeUpdate::kInvalid);  // no anchor 4
  EXPECT_EQ(tracker.add_anchor_range(0, 0, -1.0, 0.05), RangeUpdate::kInvalid);
  EXPECT_EQ(tracker.add_anchor_range(0, 0, NAN, 0.05), RangeUpdate::kInvalid);
  EXPECT_EQ(tracker.add_anchor_range(0, 0, 1.0, 0.0), RangeUpdate::kInvalid);
  EXPECT_EQ(tracker.add_mobile_range(0, {1, 1, NAN}, 0.01, 1.0, 0.05), RangeUpdate::kInvalid);
  const Eigen::Vector3d tag(2.0, 1.5, 1.0);
  for (std::size_t a = 0; a < kAnchors.size(); ++a)
    tracker.add_anchor_range(static_cast<std::int64_t>(100 + a) * kMs, a, (kAnchors[a] - tag).norm(), 0.05);
  ASSERT_TRUE(tracker.started());
  EXPECT_EQ(tracker.add_anchor_range(50 * kMs, 0, (kAnchors[0] - tag).norm(), 0.05), RangeUpdate::kOutOfOrder);
  EXPECT_STREQ(range_update_word(RangeUpdate::kOutOfOrder), "out_of_order");
  // A long silence: the next range starts over (a new first fix) rather than trusting a
  // prediction seconds old.
  EXPECT_EQ(tracker.add_anchor_range(5000 * kMs, 0, (kAnchors[0] - tag).norm(), 0.05), RangeUpdate::kInitialising);
  EXPECT_FALSE(tracker.started());
  EXPECT_EQ(tracker.restarts(), 1u);
}

TEST(RangeTracker, AMobileReferenceCountsWithItsOwnUncertainty) {
  // Two fixed anchors at a known height leave x, y ambiguous (a mirror image about the line
  // through them); the range to another robot whose position is known to 1 cm settles it.
  RangeTrackerOptions options;
  options.known_height = 0.3;
  const std::vector<Eigen::Vector3d> three(kAnchors.begin(), kAnchors.begin() + 2);
  RangeTracker tracker(three, options);
  const Eigen::Vector3d tag(2.0, 1.5, 0.3), other(4.0, 3.0, 0.3);
  for (int i = 0; i < 300; ++i) {
    const std::int64_t t = static_cast<std::int64_t>(i) * 10 * kMs;
    if (i % 3 == 2) {
      tracker.add_mobile_range(t, other, 0.01, (other - tag).norm(), 0.02);
    } else {
      const std::size_t a = static_cast<std::size_t>(i % 3);
      tracker.add_anchor_range(t, a, (three[a] - tag).norm(), 0.02);
    }
  }
  const auto s = tracker.state();
  ASSERT_TRUE(s);
  EXPECT_LT((s->position - tag).head<2>().norm(), 1e-3);
}

}  // namespace
}  // namespace ips
