// A firing's odometry (the distance its tag travelled since its previous firing) through the
// range fixer, against the exact circle the tag drives: tracked, a speed; solved per firing, a
// range to the previous fix. Firings lost on the way leave the next one's odometry unused.
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

RangingConfig lab(bool track) {
  RangingConfig c = test::ranging_lab();
  c.height = 0.3;
  c.track = track;
  return c;
}

// A robot on a circle (r 0.6 m, 0.3 m/s) firing four 5 cm ranges at 10 Hz for 60 s; its wheels
// measure each firing's 3 cm of travel to 1 mm. 5 % of the firings are lost.
struct OdometryRun {
  std::vector<double> errors_2d;  // after the first 5 s
  RangeFixCounters counters;
};

OdometryRun drive(bool track, bool odometry) {
  RangeFixer fixer(lab(track));
  const RangingConfig c = lab(track);
  const auto truth = [](double t) {
    const double a = 0.5 * t;
    return Eigen::Vector3d(2.0 + 0.6 * std::cos(a), 1.5 + 0.6 * std::sin(a), 0.3);
  };
  std::mt19937 rng(21), odometry_rng(22);
  std::normal_distribution<double> noise(0.0, 0.05), wheel(0.0, 0.001);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  OdometryRun run;
  for (int i = 0; i < 600; ++i) {
    const double t = 0.1 * i;
    AdmittedFiring f;
    f.firing.tag = 7;
    f.firing.firing = static_cast<std::uint32_t>(i);
    f.t_mono_ns = static_cast<std::int64_t>(i) * 100'000'000;
    for (const auto& [id, a] : c.anchors)
      f.firing.entries.push_back({id, false, (a.position - truth(t)).norm() + noise(rng), 0.05});
    const double travelled = 0.03 + wheel(odometry_rng);
    if (odometry) {
      f.firing.odometry_m = travelled;
      f.firing.odometry_sigma_m = 0.001;
    }
    if (u01(rng) < 0.05) continue;  // lost on the way (drawn after the noise: the same ranges either way)
    const auto o = fixer.fix(f, 0);
    if (o && t > 5.0) run.errors_2d.push_back((o->p_world - truth(t)).head<2>().norm());
  }
  run.counters = fixer.counters();
  return run;
}

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(0.95 * double(v.size() - 1))];
}

TEST(RangeFixerOdometry, TrackedTheDistanceTravelledIsASpeed) {
  const OdometryRun with = drive(true, true), without = drive(true, false);
  std::printf("tracked, 5 cm ranges at 10 Hz: p95 2-D %.1f mm with odometry, %.1f mm without\n",
              1e3 * p95(with.errors_2d), 1e3 * p95(without.errors_2d));
  ASSERT_GT(with.errors_2d.size(), 500u);
  EXPECT_LT(p95(with.errors_2d), 0.85 * p95(without.errors_2d));
  // Every firing after one that was lost cannot use its odometry (~5 % of ~570).
  const auto& o = with.counters.odometry;
  EXPECT_GT(o.at("accepted"), 480u);
  EXPECT_GT(o.at("no_previous"), 10u);
  EXPECT_LT(o.at("no_previous"), 60u);
  EXPECT_TRUE(without.counters.odometry.empty());
}

TEST(RangeFixerOdometry, SolvedPerFiringItIsARangeToThePreviousFix) {
  const OdometryRun with = drive(false, true), without = drive(false, false);
  std::printf("solved per firing, 5 cm ranges at 10 Hz: p95 2-D %.1f mm with odometry, %.1f mm without\n",
              1e3 * p95(with.errors_2d), 1e3 * p95(without.errors_2d));
  ASSERT_GT(with.errors_2d.size(), 500u);
  EXPECT_LT(p95(with.errors_2d), p95(without.errors_2d));
  EXPECT_GT(with.counters.odometry.at("sphere"), 480u);
  EXPECT_GT(with.counters.odometry.at("no_previous"), 10u);
}

}  // namespace
}  // namespace ips
