// A ranging tag on a body (ips/body/body_track.h, "Ranges"): where the cameras do not place the
// body, its tag's fixes do — the tag's offset turned by the last measured orientation taken off,
// the heading held, sources = ranges; where they do (within the camera hold), the fixes wait.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ips/body/body_track.h"

namespace ips {
namespace {

std::vector<BodyDef> robot() {
  BodyDef b;
  b.name = "rover";
  b.markers = {flat_marker(7, 0.1, {0.0, 0, 0.25}, 0.0)};
  return {b};
}

// Camera 0's view of the robot's marker, the robot at (x, y) heading `yaw`.
BodyObservation view(double x, double y, double yaw, std::int64_t t_ns) {
  BodyObservation o;
  o.body = 0;
  o.id = 7;
  o.camera_index = 0;
  o.face = FaceClass::kUp;
  o.faces = {0};
  o.yaws = {yaw};
  o.qs = {Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()))};
  o.positions = {Eigen::Vector3d(x, y, 0)};
  o.marker_centre = Eigen::Vector3d(x, y, 0.25);
  o.area_px = 900;
  o.t_mono_ns = o.t_real_ns = t_ns;
  return o;
}

WorldObservation fix(const Eigen::Vector3d& p, std::int64_t t_ns, double sigma = 0.05) {
  WorldObservation o;
  o.id = -1;
  o.source = ObservationSource::kRanges;
  o.has_yaw = false;
  o.p_world = p;
  o.covariance = sigma * sigma * Eigen::Matrix3d::Identity();
  o.t_mono_ns = o.t_real_ns = t_ns;
  return o;
}

const FusionMethod& mean() { return find_fusion_method("mean", "test"); }
constexpr std::int64_t kMs = 1'000'000;

TEST(BodyTrackRanges, CamerasFirstThenTheTagPlacesTheBodyWithItsOffsetTurnedByTheHeldHeading) {
  BodyTrack track(robot());
  std::vector<FusedBody> out;
  // Seen by camera 0 at (1, 2) heading 90 deg until t = 1 s.
  for (int k = 0; k <= 30; ++k) {
    const std::int64_t t = k * 33 * kMs;
    const std::vector<BodyObservation> v{view(1.0, 2.0, M_PI / 2, t)};
    track.add(0, t, t, v, mean(), out);
  }
  ASSERT_FALSE(out.empty());
  EXPECT_EQ(out.back().sources, source_bit(ObservationSource::kCamera));
  // Camera-placed: camera_sigma^2 per axis (one camera, no spread).
  EXPECT_NEAR(out.back().covariance(0, 0), 0.002 * 0.002, 1e-12);
  const std::int64_t last_camera = 30 * 33 * kMs;
  // The tag sits 0.3 m ahead of the origin along the body x axis, which points along world +y.
  const Eigen::Vector3d offset(0.3, 0.0, 0.1);
  // A fix 0.2 s after the last camera frame: within the hold (0.5 s), merged for nothing.
  out.clear();
  track.add_fix("rover", offset, fix({1.0, 2.3, 0.1}, last_camera + 200 * kMs), 0.5, out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(track.held_for_cameras(), 1u);
  // 0.6 s after: the tag places the body. Origin = tag - R(90 deg) * offset = (1.0, 2.0, 0.0).
  track.add_fix("rover", offset, fix({1.0, 2.3, 0.1}, last_camera + 600 * kMs), 0.5, out);
  ASSERT_EQ(out.size(), 1u);
  const FusedBody& b = out[0];
  EXPECT_EQ(b.name, "rover");
  EXPECT_EQ(b.sources, source_bit(ObservationSource::kRanges));
  EXPECT_EQ(b.camera_mask, 0u);
  EXPECT_FALSE(b.has_yaw);
  EXPECT_NEAR(b.pose.yaw, M_PI / 2, 1e-9);  // held
  EXPECT_NEAR(b.pose.position.x(), 1.0, 1e-9);
  EXPECT_NEAR(b.pose.position.y(), 2.0, 1e-9);
  EXPECT_NEAR(b.pose.position.z(), 0.0, 1e-9);
  EXPECT_NEAR(b.covariance(1, 1), 0.05 * 0.05, 1e-12);  // the fix's
  EXPECT_EQ(b.t_mono_ns, last_camera + 600 * kMs);
}

TEST(BodyTrackRanges, NeverBackInTimeAndUnknownBodiesIgnored) {
  BodyTrack track(robot());
  std::vector<FusedBody> out;
  // Never seen by a camera: identity orientation, the offset taken off as is.
  track.add_fix("rover", {0.1, 0, 0}, fix({2.1, 1.0, 0.0}, 1000 * kMs), 0.5, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].pose.position.x(), 2.0, 1e-9);
  // 0.1 s later, 5 cm further along x: the filter moves part of the way and gains a velocity
  // towards it (a fix alone is 5 cm noisy).
  track.add_fix("rover", {0.1, 0, 0}, fix({2.15, 1.0, 0.0}, 1100 * kMs), 0.5, out);
  ASSERT_EQ(out.size(), 2u);
  ASSERT_TRUE(out[1].has_velocity);
  EXPECT_GT(out[1].velocity.x(), 0.05);
  EXPECT_LE(out[1].velocity.x(), 0.5);
  EXPECT_GT(out[1].pose.position.x(), 2.0);
  EXPECT_LT(out[1].pose.position.x(), 2.05);
  EXPECT_LT(out[1].covariance(0, 0), 0.05 * 0.05) << "two fixes know more than one";
  // Older than the last published pose: late, nothing published.
  track.add_fix("rover", {0.1, 0, 0}, fix({2.1, 1.0, 0.0}, 1050 * kMs), 0.5, out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(track.late(), 1u);
  // A camera frame older than the ranges' last pose: merged, not published (late).
  const std::vector<BodyObservation> v{view(2.1, 1.0, 0.0, 1080 * kMs)};
  track.add(0, 1080 * kMs, 1080 * kMs, v, mean(), out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(track.late(), 2u);
  // ... and now the cameras have it: the next fix within the hold waits for them.
  track.add_fix("rover", {0.1, 0, 0}, fix({2.2, 1.0, 0.0}, 1200 * kMs), 0.5, out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(track.held_for_cameras(), 1u);
  track.add_fix("nobody", {0, 0, 0}, fix({0, 0, 0}, 5000 * kMs), 0.5, out);
  EXPECT_EQ(out.size(), 2u);
}

// A body standing still, its tag's fixes 5 cm noisy at 10 Hz: the published positions scatter
// less than the fixes (the constant-velocity filter that carries it between the cameras).
TEST(BodyTrackRanges, TheFixesAreSmoothed) {
  BodyTrack track(robot());
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<FusedBody> out;
  double raw = 0, published = 0;
  int n = 0;
  for (int k = 0; k < 100; ++k) {
    const Eigen::Vector3d p(3.0 + noise(rng), 1.0 + noise(rng), 0.0);
    track.add_fix("rover", Eigen::Vector3d::Zero(), fix(p, k * 100 * kMs), 0.5, out);
    ASSERT_EQ(out.size(), static_cast<std::size_t>(k + 1));
    if (k < 20) continue;  // the filter settling
    raw += (p - Eigen::Vector3d(3, 1, 0)).head<2>().squaredNorm();
    published += (out.back().pose.position - Eigen::Vector3d(3, 1, 0)).head<2>().squaredNorm();
    ++n;
  }
  const double raw_rms = std::sqrt(raw / n), published_rms = std::sqrt(published / n);
  EXPECT_NEAR(raw_rms, 0.05 * std::sqrt(2.0), 0.015);
  EXPECT_LT(published_rms, 0.6 * raw_rms) << "raw " << raw_rms << " published " << published_rms;
}

}  // namespace
}  // namespace ips
