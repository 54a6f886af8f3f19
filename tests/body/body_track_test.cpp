// The daemon's asynchronous body fusion (ips/body/body_track.h) on hand-made views: one pose per
// frame at the frame's time, other cameras' older views moved forward by the body's velocity,
// and a body's stream never going back in time.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "ips/body/body_track.h"

namespace ips {
namespace {

// A ground robot with two flat markers 40 cm apart along its x axis.
std::vector<BodyDef> two_marker_robot() {
  BodyDef b;
  b.name = "long";
  b.markers = {flat_marker(7, 0.1, {0.2, 0, 0.25}, 0.0), flat_marker(8, 0.1, {-0.2, 0, 0.25}, 0.0)};
  return {b};
}

// What a camera would report for marker `face` of the robot at (x, y), heading `yaw` (the
// marker centre is only used for the baseline yaw of two markers, written for heading 0).
BodyObservation view(int camera, int face, double x, double y, std::int64_t t_ns, double yaw = 0.0) {
  BodyObservation o;
  o.body = 0;
  o.id = face == 0 ? 7 : 8;
  o.camera_index = camera;
  o.face = FaceClass::kUp;
  o.faces = {face};
  o.yaws = {yaw};
  o.qs = {Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()))};
  o.positions = {Eigen::Vector3d(x, y, 0)};
  o.marker_centre = Eigen::Vector3d(x + (face == 0 ? 0.2 : -0.2), y, 0.25);
  o.area_px = 900;
  o.t_mono_ns = o.t_real_ns = t_ns;
  return o;
}

const FusionMethod& mean() { return find_fusion_method("mean", "test"); }

TEST(BodyTrack, OnePoseAtTheFrameTimeFromTheMarkersOfSeveralCameras) {
  BodyTrack track(two_marker_robot());
  std::vector<FusedBody> out;
  // Camera 0 sees marker 7 at t = 0; camera 1 sees marker 8 at t = 0 too: the baseline gives yaw.
  const std::vector<BodyObservation> a{view(0, 0, 1.0, 2.0, 0)};
  track.add(0, 0, 0, a, mean(), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].marker_ids, std::vector<int>{7});
  out.clear();
  const std::vector<BodyObservation> b{view(1, 1, 1.0, 2.0, 0)};
  track.add(1, 0, 0, b, mean(), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].name, "long");
  EXPECT_EQ(out[0].marker_ids, (std::vector<int>{7, 8}));
  EXPECT_EQ(out[0].camera_mask, 3u);
  EXPECT_NEAR(out[0].pose.position.x(), 1.0, 1e-9);
  EXPECT_NEAR(out[0].pose.position.y(), 2.0, 1e-9);
  EXPECT_TRUE(out[0].has_yaw);
  EXPECT_NEAR(out[0].pose.yaw, 0.0, 1e-9);
}

TEST(BodyTrack, OtherCamerasViewsAreMovedForwardByTheBodysVelocity) {
  BodyTrack track(two_marker_robot());
  std::vector<FusedBody> out;
  // The robot drives along +x at 1 m/s; camera 0 sees it every 20 ms, giving the velocity.
  for (int k = 0; k <= 5; ++k) {
    const std::int64_t t = k * 20'000'000LL;
    const std::vector<BodyObservation> v{view(0, 0, 0.02 * k, 0.0, t)};
    track.add(0, t, t, v, mean(), out);
  }
  // Camera 1 reports marker 8 at t = 110 ms (x = 0.11); at t = 120 ms camera 0's marker 7
  // (x = 0.12) is fused with camera 1's view moved 10 ms forward (x = 0.12, not 0.11).
  out.clear();
  const std::vector<BodyObservation> c1{view(1, 1, 0.11, 0.0, 110'000'000)};
  track.add(1, 110'000'000, 110'000'000, c1, mean(), out);
  out.clear();
  const std::vector<BodyObservation> c0{view(0, 0, 0.12, 0.0, 120'000'000)};
  track.add(0, 120'000'000, 120'000'000, c0, mean(), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].camera_mask, 3u);
  EXPECT_EQ(out[0].t_mono_ns, 120'000'000);
  EXPECT_NEAR(out[0].pose.position.x(), 0.12, 1e-6);
  EXPECT_NEAR(out[0].pose.yaw, 0.0, 1e-6);
}

TEST(BodyTrack, EachPoseCarriesTheVelocityAndYawRateOverTheSpanTheShortWayRound) {
  BodyTrackOptions options;
  options.velocity_span_s = 0.1;
  BodyTrack track(two_marker_robot(), options);
  // 0.6 m/s along +x and 0.4 m/s along -y, turning at +2 rad/s through +-pi (yaw 3.0 -> -3.04).
  auto yaw_at = [](double t) { return std::remainder(3.0 + 2.0 * t, 2 * M_PI); };
  std::vector<FusedBody> out;
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.02 * k;
    const auto t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    const std::vector<BodyObservation> v{view(0, 0, 1.0 + 0.6 * t, 2.0 - 0.4 * t, t_ns, yaw_at(t))};
    track.add(0, t_ns, t_ns, v, mean(), out);
  }
  ASSERT_EQ(out.size(), 11u);
  EXPECT_FALSE(out[0].has_velocity);  // one pose: nothing to difference
  EXPECT_FALSE(out[0].has_yaw_rate);
  for (std::size_t k = 1; k < out.size(); ++k) {
    ASSERT_TRUE(out[k].has_velocity) << k;
    ASSERT_TRUE(out[k].has_yaw_rate) << k;
    EXPECT_NEAR(out[k].velocity.x(), 0.6, 1e-6) << k;
    EXPECT_NEAR(out[k].velocity.y(), -0.4, 1e-6) << k;
    EXPECT_NEAR(out[k].velocity.z(), 0.0, 1e-9) << k;
    EXPECT_NEAR(out[k].yaw_rate, 2.0, 1e-6) << k;  // not -6.3 rad/s across the wrap
  }
  EXPECT_LT(out[10].pose.yaw, 0.0);  // the turn went through +-pi
}

// A robot turning in place at 41 deg/s, one marker seen by each of two unsynchronised cameras
// (33 ms frames, camera 1 31 ms after camera 0): every pose fuses the frame's marker with the
// other camera's older one, whose yaw and marker centre must be turned forward too. Measured
// from outside before the older views were turned: the fused yaw lagged by 0.68 deg on average.
TEST(BodyTrack, OtherCamerasViewsAreTurnedForwardByTheBodysYawRate) {
  BodyTrack track(two_marker_robot());
  const double omega = 41.0 * M_PI / 180.0;
  const Eigen::Vector3d origin(1.0, 2.0, 0.0);
  auto turning_view = [&](int camera, int face, std::int64_t t_ns) {
    const double yaw = std::remainder(omega * 1e-9 * static_cast<double>(t_ns), 2 * M_PI);
    BodyObservation o = view(camera, face, origin.x(), origin.y(), t_ns, yaw);
    const Eigen::Vector3d offset(face == 0 ? 0.2 : -0.2, 0.0, 0.25);
    o.marker_centre = origin + Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * offset;
    return o;
  };
  std::vector<FusedBody> out;
  double worst_deg = 0;
  int fused_from_both = 0;
  for (int k = 0; k < 60; ++k) {
    for (int camera : {0, 1}) {
      const std::int64_t t = k * 33'000'000LL + camera * 31'000'000LL;
      const std::vector<BodyObservation> v{turning_view(camera, camera, t)};
      out.clear();
      track.add(camera, t, t, v, mean(), out);
      ASSERT_EQ(out.size(), 1u);
      // The first poses, before there is a yaw rate, lag; their echo in the rate over the span
      // decays within a second.
      if (k < 30 || out[0].camera_mask != 3u) continue;
      ++fused_from_both;
      const double truth = omega * 1e-9 * static_cast<double>(t);
      const double error_deg = std::remainder(out[0].pose.yaw - truth, 2 * M_PI) * 180.0 / M_PI;
      worst_deg = std::max(worst_deg, std::abs(error_deg));
      EXPECT_NEAR(out[0].pose.position.x(), origin.x(), 1e-5);
      EXPECT_NEAR(out[0].pose.position.y(), origin.y(), 1e-5);
    }
  }
  EXPECT_EQ(fused_from_both, 60);
  // The yaw rate over the span is exact for a constant turn: nothing but rounding is left.
  EXPECT_LT(worst_deg, 0.005);
}

TEST(BodyTrack, ALateFrameIsMergedButNeverPublishedBackInTime) {
  BodyTrack track(two_marker_robot());
  std::vector<FusedBody> out;
  const std::vector<BodyObservation> now{view(0, 0, 1.0, 1.0, 100'000'000)};
  track.add(0, 100'000'000, 100'000'000, now, mean(), out);
  ASSERT_EQ(out.size(), 1u);
  out.clear();
  const std::vector<BodyObservation> late{view(1, 1, 1.0, 1.0, 90'000'000)};
  track.add(1, 90'000'000, 90'000'000, late, mean(), out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(track.late(), 1u);
  // The late view still counts for the next output within the window.
  const std::vector<BodyObservation> next{view(0, 0, 1.0, 1.0, 120'000'000)};
  track.add(0, 120'000'000, 120'000'000, next, mean(), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].marker_ids, (std::vector<int>{7, 8}));
  // Fixed-rate output: the newest pose, at its own time.
  std::vector<FusedBody> latest;
  track.latest(150'000'000, latest);
  ASSERT_EQ(latest.size(), 1u);
  EXPECT_EQ(latest[0].t_mono_ns, 120'000'000);
  latest.clear();
  track.latest(120'000'000 + 300'000'000, latest);  // older than history_s: gone
  EXPECT_TRUE(latest.empty());
  // A reload keeps the order: the new track publishes nothing older than 120 ms.
  BodyTrack fresh(two_marker_robot());
  fresh.continue_after(track);
  out.clear();
  const std::vector<BodyObservation> old{view(0, 0, 1.0, 1.0, 110'000'000)};
  fresh.add(0, 110'000'000, 110'000'000, old, mean(), out);
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace ips
