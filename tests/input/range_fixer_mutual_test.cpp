// Two robots ranging to each other out of the cameras' view (ranging.track.mutual,
// ips/input/range_fixer.h): a range between two tags is a measurement of both, so it updates
// the track of the tag ranged to as well as the firing tag's. Truth: the exact trajectories.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ips/input/range_fixer.h"
#include "ranging_lab.h"

namespace ips {
namespace {

// Robot A (tag 7, marker 20) drives a circle in the 4 x 3 m room (r 0.6 m, 0.3 m/s) and ranges
// to the room's four anchors and to robot B. Robot B (tag 8, marker 21) drives a circle in the
// corridor beyond the room's x = 4 m wall (centre (5.5, 1.5), r 0.4 m, 0.2 m/s), where only
// anchors 2 and 3 (both on that wall) reach it: two ranges at a known height leave B's side of
// the wall open. Both fire at 10 Hz, 50 ms apart, 5 cm ranges; 30 s. Neither is seen by the
// cameras; each robot's published state is its latest fix, as the daemon publishes it.
struct MutualRun {
  std::vector<double> a_2d, b_2d;  // 2-D error of each published fix
  int b_outside_3_sigma = 0;       // B's fixes whose error exceeds 3 sigma of their own covariance
  RangeFixCounters counters;
};

Eigen::Vector3d robot_a(double t) {
  const double w = 0.3 / 0.6;
  return {2.0 + 0.6 * std::cos(w * t), 1.5 + 0.6 * std::sin(w * t), 0.3};
}
Eigen::Vector3d robot_b(double t) {
  const double w = 0.2 / 0.4;
  return {5.5 + 0.4 * std::cos(-w * t), 1.5 + 0.4 * std::sin(-w * t), 0.3};
}

MutualRun run_pair(bool mutual, bool b_ranges_to_a, bool cameras_see_b = false) {
  RangingConfig c = test::ranging_lab();
  c.height = 0.3;
  c.tags[8] = RangingTag::on_marker(21);
  c.track_mutual = mutual;
  std::map<int, MobileReference> published;  // by marker
  std::int64_t now = 0;
  RangeFixer fixer(c, [&](const RangingTag& carrier) -> std::optional<MobileReference> {
    if (cameras_see_b && carrier.marker == 21) {  // the cameras' view of B: exact, now
      MobileReference m;
      m.t_mono_ns = now;
      m.position = robot_b(1e-9 * static_cast<double>(now));
      m.covariance = 1e-6 * Eigen::Matrix3d::Identity();
      m.seen_by_cameras = true;
      return m;
    }
    const auto p = published.find(carrier.marker);
    if (p == published.end()) return std::nullopt;
    return p->second;
  });
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  const auto range = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).norm() + noise(rng); };
  MutualRun run;
  for (int i = 0; i < 600; ++i) {
    const bool is_a = i % 2 == 0;
    const std::int64_t t_ns = 1'000'000'000 + static_cast<std::int64_t>(i) * 50'000'000;
    const double t = 1e-9 * static_cast<double>(t_ns);
    now = t_ns;
    const Eigen::Vector3d a = robot_a(t), b = robot_b(t);
    AdmittedFiring f;
    f.firing.tag = is_a ? 7 : 8;
    f.firing.firing = static_cast<std::uint32_t>(i / 2);
    f.t_mono_ns = t_ns;
    const Eigen::Vector3d& self = is_a ? a : b;
    for (const auto& [id, anchor] : c.anchors)
      if (is_a || id == 2 || id == 3) f.firing.entries.push_back({id, false, range(anchor.position, self), 0.05});
    if (is_a || b_ranges_to_a) f.firing.entries.push_back({is_a ? 8u : 7u, true, range(a, b), 0.05});
    const auto o = fixer.fix(f, 0);
    if (!o) continue;
    MobileReference m;
    m.position = o->p_world;
    m.covariance = o->covariance;
    m.t_mono_ns = t_ns;
    published[is_a ? 20 : 21] = m;
    if (t < 6.0) continue;  // the tracks' first seconds: settling
    const Eigen::Vector2d e = (o->p_world - self).head<2>();
    (is_a ? run.a_2d : run.b_2d).push_back(e.norm());
    if (!is_a && e.dot(o->covariance.topLeftCorner<2, 2>().inverse() * e) > 11.83) ++run.b_outside_3_sigma;
  }
  run.counters = fixer.counters();
  return run;
}

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 1e9 : v[static_cast<std::size_t>(0.95 * static_cast<double>(v.size() - 1))];
}

TEST(RangeFixerMutual, ARobotThatOnlyAnswersIsPlacedByTheRangesOfTheRobotThatAsks) {
  // B's own firings carry two anchors only: alone it never has the three references a first
  // fix at a known height needs, and A's ranges to B find no published state of B to use.
  const MutualRun off = run_pair(false, false);
  EXPECT_TRUE(off.b_2d.empty());
  EXPECT_EQ(off.counters.mobile_references, 0u);
  EXPECT_EQ(off.counters.mobile_references_unknown, 300u);
  EXPECT_TRUE(off.counters.mutual.empty());
  // With the mutual update A's ranges reach B's track: B is placed on the right side of the wall.
  const MutualRun on = run_pair(true, false);
  std::printf("B answering only: %zu fixes, 2-D p95 %.1f mm, %d outside 3 sigma; A p95 %.1f mm (%.1f without)\n",
              on.b_2d.size(), 1e3 * p95(on.b_2d), on.b_outside_3_sigma, 1e3 * p95(on.a_2d), 1e3 * p95(off.a_2d));
  EXPECT_GE(on.b_2d.size(), 240u);  // every B firing from 6 s on
  EXPECT_LT(p95(on.b_2d), 0.10);
  EXPECT_GE(on.counters.mutual.at("accepted"), 250u);
  EXPECT_LT(on.b_outside_3_sigma, static_cast<int>(on.b_2d.size() / 20));  // its covariance tells the truth
  // A, now with B's published state as a reference too, is no worse for it.
  EXPECT_LT(p95(on.a_2d), 1.1 * p95(off.a_2d));
}

TEST(RangeFixerMutual, RobotsThatRangeEachOtherBothUseEveryRangeBetweenThem) {
  // B ranges to A as well: without the mutual update each range is used by the robot that
  // measured it only; with it, by both.
  const MutualRun off = run_pair(false, true);
  const MutualRun on = run_pair(true, true);
  std::printf("both ranging: B 2-D p95 %.1f mm mutual, %.1f mm each its own; outside 3 sigma %d / %zu (%d / %zu)\n",
              1e3 * p95(on.b_2d), 1e3 * p95(off.b_2d), on.b_outside_3_sigma, on.b_2d.size(), off.b_outside_3_sigma,
              off.b_2d.size());
  ASSERT_GE(off.b_2d.size(), 240u);
  ASSERT_GE(on.b_2d.size(), 240u);
  EXPECT_LT(p95(on.b_2d), p95(off.b_2d));
  EXPECT_LT(on.b_outside_3_sigma, static_cast<int>(on.b_2d.size() / 20));
}

TEST(RangeFixerMutual, ARobotTheCamerasPlaceKeepsTheirPosition) {
  // Where the cameras see B its track takes their position: A's ranges are not applied to it
  // (they would add little, and B's track would then share A's errors), and A uses B as placed
  // by the cameras.
  const MutualRun seen = run_pair(true, false, /*cameras_see_b=*/true);
  EXPECT_TRUE(seen.counters.mutual.empty());
  EXPECT_EQ(seen.counters.mobile_references, 300u);
  EXPECT_GE(seen.counters.camera_references, 290u);
  ASSERT_GE(seen.b_2d.size(), 240u);
  EXPECT_LT(p95(seen.b_2d), 0.01);
}

}  // namespace
}  // namespace ips
