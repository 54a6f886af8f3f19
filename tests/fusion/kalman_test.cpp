#include "ips/fusion/kalman.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace ips {
namespace {

FusedMarker at(double x, double y, std::int64_t t_ns) {
  FusedMarker m;
  m.id = 3;
  m.p_world = {x, y, 0.1};
  m.t_mono_ns = t_ns;
  return m;
}

TEST(Kalman, ConstantVelocityTrackConvergesToTheTrueVelocity) {
  MarkerTracker tracker;
  const double vx = 0.4, vy = -0.3;  // m/s
  FusedMarker m;
  for (int k = 0; k <= 90; ++k) {  // 3 s at 30 Hz, exact measurements
    const double t = k / 30.0;
    m = at(1.0 + vx * t, 2.0 + vy * t, static_cast<std::int64_t>(std::llround(t * 1e9)));
    tracker.update(m);
  }
  EXPECT_TRUE(m.has_velocity);
  EXPECT_NEAR(m.velocity.x(), vx, 2e-3);
  EXPECT_NEAR(m.velocity.y(), vy, 2e-3);
  EXPECT_NEAR(m.velocity.z(), 0.0, 1e-9);
  EXPECT_NEAR(m.p_world.x(), 1.0 + vx * 3.0, 1e-3);
}

TEST(Kalman, SmoothsNoiseOnAStationaryMarker) {
  KalmanOptions o;
  o.measurement_noise = 0.01 * 0.01;
  o.process_noise = 0.05;  // a slow robot: trust the model more
  MarkerTracker tracker(o);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  double raw_sq = 0, filtered_sq = 0;
  for (int k = 0; k < 300; ++k) {
    const double e = noise(rng);
    FusedMarker m = at(2.0 + e, 0.0, k * 33'333'333LL);
    tracker.update(m);
    if (k >= 30) {
      raw_sq += e * e;
      filtered_sq += (m.p_world.x() - 2.0) * (m.p_world.x() - 2.0);
    }
  }
  EXPECT_LT(filtered_sq, 0.5 * raw_sq);  // at least halves the noise power
}

TEST(Kalman, ALongGapRestartsTheTrack) {
  MarkerTracker tracker;
  for (int k = 0; k < 30; ++k) {
    FusedMarker m = at(0.5 * k / 30.0, 0, k * 33'333'333LL);
    tracker.update(m);
  }
  FusedMarker later = at(5.0, 5.0, 10'000'000'000LL);  // 9 s later, somewhere else
  tracker.update(later);
  EXPECT_DOUBLE_EQ(later.p_world.x(), 5.0);
  EXPECT_DOUBLE_EQ(later.velocity.x(), 0.0);
  EXPECT_EQ(tracker.tracks(), 1u);
}

}  // namespace
}  // namespace ips
