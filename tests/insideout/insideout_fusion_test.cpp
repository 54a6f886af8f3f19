// The robot's own camera as a source of fusion (docs/inside-out.md, "Live, in ipsd"), on
// simulated time: a robot drives at 0.5 m/s, an overhead camera sees its marker at 10 Hz and
// its own camera places it 30 ms before each overhead frame. Where both see it, every overhead
// record carries both sources and the information-weighted mean of the two (hand-computed);
// where the overhead camera has lost it, the robot camera's poses are the records, with their
// heading, after fusion's hold; a record never goes back in time.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "ips/fusion/track_fusion.h"
#include "ips/insideout/on_robot.h"

namespace ips {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr int kRobot = 5;

Eigen::Vector3d truth(std::int64_t t) { return {1.0 + 0.5e-9 * static_cast<double>(t), 2.0, 0.15}; }

FrameObservations batch(int camera, std::int64_t t, std::vector<WorldObservation> o) {
  FrameObservations b;
  b.camera_index = camera;
  b.t_mono_ns = t;
  b.t_real_ns = t;
  b.observations = std::move(o);
  return b;
}

TEST(InsideOutFusion, TheRobotsOwnCameraAndAnOverheadCameraMakeOneTrack) {
  OnRobotSettings settings;
  settings.marker = kRobot;
  settings.map_sigma_m = 0.01;
  TrackFusion fusion;  // camera_sigma 2 mm, hold 0.5 s
  const FusionMethod& mean = find_fusion_method("mean", "");
  std::vector<FusedMarker> both, alone;
  std::int64_t last_published = 0;
  for (int k = 1; k <= 40; ++k) {
    const std::int64_t t = k * 100 * kMs;
    // The robot's camera: 4 mm behind the truth along x, heading 0.1 rad, its own covariance tiny.
    Localisation l;
    l.ok = true;
    l.pose.position = truth(t - 30 * kMs) + Eigen::Vector3d(-0.004, 0, 0);
    l.pose.yaw = 0.1;
    l.pose.covariance = 1e-8 * Eigen::Matrix4d::Identity();
    const WorldObservation own = robot_observation(l, settings, 1, t - 30 * kMs, t - 30 * kMs);
    EXPECT_EQ(own.source, ObservationSource::kInsideOut);
    EXPECT_NEAR(own.covariance(0, 0), 1e-8 + 1e-4, 1e-12) << "the pose's own plus the map's";
    std::vector<FusedMarker> out;
    fusion.add(batch(1, own.t_mono_ns, {own}), mean, &out);
    // The very first pose is published (no camera had the robot yet); then the camera holds.
    if (k == 1) EXPECT_EQ(out.size(), 1u);
    if (k > 1 && k <= 20) EXPECT_TRUE(out.empty()) << "held for the camera at k = " << k;
    for (const auto& f : out)
      if (k > 1) alone.push_back(f);
    if (k <= 20) {  // the overhead camera sees the robot for 2 s, 1 mm ahead of the truth
      WorldObservation seen;
      seen.id = kRobot;
      seen.camera_index = 0;
      seen.p_world = truth(t) + Eigen::Vector3d(0.001, 0, 0);
      seen.yaw = 0.0;
      seen.area_px = 900;
      seen.t_mono_ns = seen.t_real_ns = t;
      out.clear();
      fusion.add(batch(0, t, {seen}), mean, &out);
      for (const auto& f : out) both.push_back(f);
    }
    for (const auto& f : out) {
      EXPECT_GE(f.t_mono_ns, last_published) << "back in time";
      last_published = f.t_mono_ns;
    }
  }
  // Under the overhead camera: one record per overhead frame, both sources. From the third
  // frame on the robot camera's stream has a velocity (2 poses within 0.2 s), so its pose of
  // 30 ms before is moved to the frame's time exactly (the motion is linear): -4 mm against
  // the camera's +1 mm, weighed 1 / (1e-4 + 1e-8) against 1 / 0.002^2.
  ASSERT_EQ(both.size(), 20u);
  const double w_own = 1 / (1e-4 + 1e-8), w_cam = 1 / 4e-6;
  const double expected_dx = (0.001 * w_cam - 0.004 * w_own) / (w_cam + w_own);
  for (std::size_t i = 2; i < both.size(); ++i) {
    const FusedMarker& f = both[i];
    SCOPED_TRACE(i);
    EXPECT_EQ(f.sources, source_bit(ObservationSource::kCamera) | source_bit(ObservationSource::kInsideOut));
    EXPECT_EQ(f.camera_mask, 1u) << "only the overhead camera is in the camera mask";
    EXPECT_NEAR(f.p_world.x() - truth(f.t_mono_ns).x(), expected_dx, 1e-6);
    EXPECT_NEAR(f.p_world.y(), 2.0, 1e-9);
  }
  EXPECT_GT(fusion.counters().held_for_cameras, 15u) << "the robot camera's poses under the camera publish nothing";
  // Out of the overhead camera's view: after the hold (0.5 s) the robot camera's poses are the
  // records, camera mask 0, its heading measured, within the filter's lag of its own -4 mm.
  ASSERT_GE(alone.size(), 10u);
  for (const FusedMarker& f : alone) {
    EXPECT_GT(f.t_mono_ns, 2000 * kMs + 400 * kMs);
    EXPECT_EQ(f.sources, source_bit(ObservationSource::kInsideOut));
    EXPECT_EQ(f.camera_mask, 0u);
    EXPECT_TRUE(f.has_yaw);
    EXPECT_NEAR(f.yaw, 0.1, 1e-9);
    EXPECT_NEAR((f.p_world - truth(f.t_mono_ns)).head<2>().norm(), 0.004, 0.01);
  }
}

}  // namespace
}  // namespace ips
