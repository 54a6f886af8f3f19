// The bumped-camera check's own logic on hand-made observations: the median over the window,
// one warning per crossing, the "back" hysteresis, per-camera separation, and readings.
#include <gtest/gtest.h>

#include "ips/fusion/fixed_markers.h"

namespace ips {
namespace {

constexpr std::int64_t kMs = 1'000'000;

// One camera frame at `t_ms` seeing marker `id` at `p`.
FrameObservations frame(int camera, std::int64_t t_ms, int id, Eigen::Vector3d p) {
  FrameObservations b;
  b.camera_index = camera;
  b.t_mono_ns = t_ms * kMs;
  WorldObservation o;
  o.id = id;
  o.camera_index = camera;
  o.p_world = p;
  o.t_mono_ns = b.t_mono_ns;
  b.observations.push_back(o);
  return b;
}

class FixedMarkersTest : public ::testing::Test {
 protected:
  FixedMarkerMonitor monitor{{{7, Eigen::Vector3d(1.0, 2.0, 0.0)}}, FixedMarkerMonitor::Options{}};
  const Eigen::Vector3d truth{1.0, 2.0, 0.0};
};

TEST_F(FixedMarkersTest, WarnsOnceWhenTheMedianCrossesAndAgainAfterComingBack) {
  // 10 fps: 1 cm off sideways -> nothing (z, the depth formula's weak axis, is not judged).
  std::int64_t t = 0;
  for (; t < 2000; t += 100) EXPECT_TRUE(monitor.add(frame(0, t, 7, truth + Eigen::Vector3d(0.01, 0, 0.2))).empty());
  auto r = monitor.readings(t * kMs);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NEAR(r[0].error_m, 0.01, 1e-12);
  EXPECT_TRUE(r[0].seen);
  EXPECT_FALSE(r[0].moved);
  // Bumped: 5 cm (3 cm + 4 cm, a 3-4-5 triangle). The window holds 11 samples (t-1 s .. t):
  // the median crosses at the 6th bumped frame, once.
  std::vector<int> warned_at;
  for (int k = 0; k < 30; ++k, t += 100)
    for (const auto& e : monitor.add(frame(0, t, 7, truth + Eigen::Vector3d(0.03, 0.04, 0)))) {
      EXPECT_EQ(e.kind, FixedMarkerEvent::Kind::kMoved);
      EXPECT_EQ(e.camera_index, 0);
      EXPECT_EQ(e.id, 7);
      EXPECT_NEAR(e.error_m, 0.05, 1e-12);
      warned_at.push_back(k);
    }
  EXPECT_EQ(warned_at, std::vector<int>{5});
  EXPECT_TRUE(monitor.readings(t * kMs)[0].moved);
  // 2.6 cm: under the threshold but above the 80 % "back" level -> still moved, no event.
  for (int k = 0; k < 20; ++k, t += 100)
    EXPECT_TRUE(monitor.add(frame(0, t, 7, truth + Eigen::Vector3d(0, 0.026, 0))).empty());
  EXPECT_TRUE(monitor.readings(t * kMs)[0].moved);
  // Put back: one "back" event, then a second bump warns again.
  int back = 0, moved = 0;
  for (int k = 0; k < 20; ++k, t += 100)
    for (const auto& e : monitor.add(frame(0, t, 7, truth))) back += e.kind == FixedMarkerEvent::Kind::kBack;
  for (int k = 0; k < 20; ++k, t += 100)
    for (const auto& e : monitor.add(frame(0, t, 7, truth + Eigen::Vector3d(0.1, 0, 0))))
      moved += e.kind == FixedMarkerEvent::Kind::kMoved;
  EXPECT_EQ(back, 1);
  EXPECT_EQ(moved, 1);
}

TEST_F(FixedMarkersTest, OutliersCamerasAndOtherMarkersAreKeptApart) {
  // A wild frame every 4th (a misdetection 1 m away) does not move the median.
  for (std::int64_t t = 0; t < 3000; t += 100) {
    const bool wild = (t / 100) % 4 == 0;
    EXPECT_TRUE(monitor.add(frame(1, t, 7, truth + Eigen::Vector3d(wild ? 1.0 : 0.005, 0, 0))).empty());
    // Camera 2 is off by 4 cm; marker 3 is no fixed marker and is ignored.
    auto events = monitor.add(frame(2, t, 7, truth + Eigen::Vector3d(0, -0.04, 0)));
    for (const auto& e : events) EXPECT_EQ(e.camera_index, 2);
    EXPECT_TRUE(monitor.add(frame(1, t, 3, Eigen::Vector3d(9, 9, 9))).empty());
  }
  auto r = monitor.readings(3000 * kMs);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].camera_index, 1);
  EXPECT_NEAR(r[0].error_m, 0.005, 1e-12);
  EXPECT_FALSE(r[0].moved);
  EXPECT_EQ(r[1].camera_index, 2);
  EXPECT_NEAR(r[1].error_m, 0.04, 1e-12);
  EXPECT_TRUE(r[1].moved);
  // Two seconds later nobody saw it: not seen, the last value kept.
  r = monitor.readings(5100 * kMs);
  EXPECT_FALSE(r[0].seen);
  EXPECT_EQ(r[0].samples, 0u);
  EXPECT_NEAR(r[0].error_m, 0.005, 1e-12);
}

TEST_F(FixedMarkersTest, FewSamplesGiveNoVerdictAndAReconfigureStartsAfresh) {
  // Two bad frames are not enough (min_samples 3).
  EXPECT_TRUE(monitor.add(frame(0, 0, 7, truth + Eigen::Vector3d(0.2, 0, 0))).empty());
  EXPECT_TRUE(monitor.add(frame(0, 100, 7, truth + Eigen::Vector3d(0.2, 0, 0))).empty());
  EXPECT_EQ(monitor.add(frame(0, 200, 7, truth + Eigen::Vector3d(0.2, 0, 0))).size(), 1u);
  // Same configuration: history kept. The surveyed position moved to where it is seen: reset.
  monitor.configure({{7, truth}}, FixedMarkerMonitor::Options{});
  EXPECT_EQ(monitor.readings(200 * kMs).size(), 1u);
  monitor.configure({{7, truth + Eigen::Vector3d(0.2, 0, 0)}}, FixedMarkerMonitor::Options{});
  EXPECT_TRUE(monitor.readings(200 * kMs).empty());
  for (std::int64_t t = 300; t < 1000; t += 100)
    EXPECT_TRUE(monitor.add(frame(0, t, 7, truth + Eigen::Vector3d(0.2, 0, 0))).empty());
  EXPECT_NEAR(monitor.readings(1000 * kMs)[0].error_m, 0.0, 1e-12);
}

}  // namespace
}  // namespace ips
