// Asynchronous fusion (ips/fusion/track_fusion.h) against hand-computed values and against the
// truth of simulated motion, and the order guarantee under late / reordered frames.
#include "ips/fusion/track_fusion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "frame_grouper.h"

namespace ips {
namespace {

constexpr std::int64_t kMs = 1'000'000;

WorldObservation obs(int id, int cam, std::int64_t t, const Eigen::Vector3d& p, double area = 100.0) {
  WorldObservation o;
  o.id = id;
  o.camera_index = cam;
  o.p_world = p;
  o.area_px = area;
  o.t_mono_ns = t;
  o.t_real_ns = t + 1'000'000'000'000;
  return o;
}

FrameObservations frame(int cam, std::int64_t t, std::vector<WorldObservation> o) {
  FrameObservations b;
  b.camera_index = cam;
  b.t_mono_ns = t;
  b.t_real_ns = t + 1'000'000'000'000;
  b.observations = std::move(o);
  return b;
}

const FusionMethod& mean() { return find_fusion_method("mean", ""); }

// Straight line at 1 m/s along x.
Eigen::Vector3d line(std::int64_t t) { return {1e-9 * static_cast<double>(t), 0.5, 0.1}; }

TEST(TrackFusion, AnotherCamerasObservationIsMovedToTheFrameTimeByItsOwnVelocity) {
  TrackFusion f;
  std::vector<FusedMarker> out;
  // Camera 0 at 0 and 33 ms, camera 1 at 44 ms: camera 0's estimate at 44 ms is its 33 ms
  // position + 11 ms at its fitted 1 m/s, so the mean equals the truth at 44 ms exactly.
  f.add(frame(0, 0, {obs(5, 0, 0, line(0))}), mean(), &out);
  f.add(frame(0, 33 * kMs, {obs(5, 0, 33 * kMs, line(33 * kMs))}), mean(), &out);
  out.clear();
  f.add(frame(1, 44 * kMs, {obs(5, 1, 44 * kMs, line(44 * kMs))}), mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 5);
  EXPECT_EQ(out[0].t_mono_ns, 44 * kMs);
  EXPECT_EQ(out[0].t_real_ns, 44 * kMs + 1'000'000'000'000);
  EXPECT_EQ(out[0].camera_mask, 0b11u);
  EXPECT_NEAR(out[0].p_world.x(), 0.044, 1e-12);
  EXPECT_NEAR(out[0].spread, 0.0, 1e-12);
  EXPECT_TRUE(out[0].has_velocity);
  EXPECT_NEAR(out[0].velocity.x(), 1.0, 1e-9);
  // Without compensation the mean would be (0.033 + 0.044) / 2: 5.5 mm off.
}

TEST(TrackFusion, AnotherCameraWithOneFrameIsUsedOnlyAtItsOwnInstant) {
  TrackFusion f;
  std::vector<FusedMarker> out;
  f.add(frame(0, 0, {obs(1, 0, 0, {0, 0, 0})}), mean(), &out);
  out.clear();
  f.add(frame(1, 0, {obs(1, 1, 0, {0.2, 0, 0})}), mean(), &out);  // same instant: fused
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].camera_mask, 0b11u);
  EXPECT_DOUBLE_EQ(out[0].p_world.x(), 0.1);
  out.clear();
  f.add(frame(2, 10 * kMs, {obs(1, 2, 10 * kMs, {0.4, 0, 0})}), mean(), &out);  // 0 and 1 cannot be moved
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].camera_mask, 0b100u);
}

TEST(TrackFusion, ACameraOlderThanTheWindowIsLeftOut) {
  TrackFusionOptions o;
  o.window_s = 0.030;
  TrackFusion f(o);
  std::vector<FusedMarker> out;
  f.add(frame(0, 0, {obs(1, 0, 0, {0, 0, 0})}), mean(), &out);
  out.clear();
  f.add(frame(1, 31 * kMs, {obs(1, 1, 31 * kMs, {1, 0, 0})}), mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].camera_mask, 0b10u);
  EXPECT_DOUBLE_EQ(out[0].p_world.x(), 1.0);
}

TEST(TrackFusion, ALateFrameIsMergedButNotPublishedAndTooOldIsDropped) {
  TrackFusion f;  // history 0.25 s
  std::vector<FusedMarker> out;
  f.add(frame(0, 100 * kMs, {obs(3, 0, 100 * kMs, {0, 0, 0})}), mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  out.clear();
  f.add(frame(1, 80 * kMs, {obs(3, 1, 80 * kMs, {0.1, 0, 0})}), mean(), &out);  // late
  f.add(frame(1, 90 * kMs, {obs(3, 1, 90 * kMs, {0.1, 0, 0})}), mean(), &out);  // late
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(f.counters().late, 2u);
  // The late observation is used by the next output (within the 50 ms window of 110 ms).
  f.add(frame(0, 110 * kMs, {obs(3, 0, 110 * kMs, {0, 0, 0})}), mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].camera_mask, 0b11u);
  EXPECT_NEAR(out[0].p_world.x(), 0.05, 1e-12);  // camera 1 still at 0.1: velocity 0
  out.clear();
  f.add(frame(1, 110 * kMs - 260 * kMs, {obs(3, 1, -150 * kMs, {0, 0, 0})}), mean(), &out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(f.counters().too_old, 1u);
}

TEST(TrackFusion, KalmanGivesCovarianceAndVelocity) {
  TrackFusionOptions o;
  o.kalman = true;
  TrackFusion f(o);
  std::vector<FusedMarker> out;
  for (int k = 0; k < 60; ++k) {
    const std::int64_t t = k * 33 * kMs;
    f.add(frame(0, t, {obs(2, 0, t, line(t))}), mean(), &out);
  }
  ASSERT_EQ(out.size(), 60u);
  EXPECT_NEAR(out.back().velocity.x(), 1.0, 0.01);
  EXPECT_GT(out.back().covariance(0, 0), 0.0);
  EXPECT_LT(out.back().covariance(0, 0), o.kalman_options.measurement_noise);  // filtered < one measurement
}

TEST(TrackFusion, FixedRateOutputPredictsToTheTickAndNeverGoesBack) {
  TrackFusion f;
  std::vector<FusedMarker> out;
  f.add(frame(0, 0, {obs(9, 0, 0, line(0))}), mean(), nullptr);
  f.add(frame(0, 33 * kMs, {obs(9, 0, 33 * kMs, line(33 * kMs))}), mean(), nullptr);
  f.predict_all(60 * kMs, 0, mean(), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].t_mono_ns, 60 * kMs);
  EXPECT_NEAR(out[0].p_world.x(), 0.060, 1e-12);
  out.clear();
  f.predict_all(50 * kMs, 0, mean(), out);  // earlier than published: nothing
  EXPECT_TRUE(out.empty());
}

WorldObservation ray_obs(int id, int cam, std::int64_t t, const Eigen::Vector3d& centre, const Eigen::Vector3d& target,
                         double depth_error) {
  // What the camera worker makes without a height: the depth-formula point (off along the ray
  // by `depth_error`) plus the ray itself.
  WorldObservation o = obs(id, cam, t, {0, 0, 0});
  o.height_known = false;
  o.has_ray = true;
  o.ray_origin = centre;
  o.ray_direction = (target - centre).normalized();
  o.p_world = target + depth_error * o.ray_direction;
  return o;
}

TEST(TrackFusion, TwoCamerasRaysAreTriangulatedWithoutAHeight) {
  const Eigen::Vector3d c0(0, 0, 3), c1(1.5, 0.2, 2.9), target(0.4, 0.3, 0.12);
  TrackFusion f;
  std::vector<FusedMarker> out;
  f.add(frame(0, 0, {ray_obs(4, 0, 0, c0, target, 0.05)}), mean(), &out);
  EXPECT_TRUE(out.empty());  // one camera, no height, single_camera_depth off
  f.add(frame(1, 0, {ray_obs(4, 1, 0, c1, target, -0.04)}), mean(), &out);  // the same instant
  ASSERT_EQ(out.size(), 1u);
  EXPECT_LT((out[0].p_world - target).norm(), 1e-9);  // the depth errors do not matter
  EXPECT_EQ(out[0].camera_mask, 0b11u);
  EXPECT_LT(out[0].spread, 1e-9);
  // A ray 1 cm off, across the plane of the two cameras and the marker (within that plane an
  // error moves the intersection along the rays instead): the spread is the ray residual,
  // the point lies between.
  out.clear();
  const Eigen::Vector3d across = (c1 - c0).cross(target - c0).normalized();
  const Eigen::Vector3d off = target + 0.01 * across;
  f.add(frame(0, 33 * kMs, {ray_obs(4, 0, 33 * kMs, c0, off, 0.0)}), mean(), &out);
  out.clear();
  f.add(frame(1, 33 * kMs, {ray_obs(4, 1, 33 * kMs, c1, target, 0.0)}), mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_GT(out[0].spread, 0.003);
  EXPECT_LT(out[0].spread, 0.01);
  EXPECT_LT((out[0].p_world - target).norm(), 0.01);
}

TEST(TrackFusion, OneCameraWithoutAHeightIsReportedOnlyIfAllowed) {
  TrackFusionOptions o;
  o.single_camera_depth = true;
  TrackFusion f(o);
  std::vector<FusedMarker> out;
  f.add(frame(0, 0, {ray_obs(4, 0, 0, {0, 0, 3}, {0.4, 0.3, 0.12}, 0.05)}), mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR((out[0].p_world - Eigen::Vector3d(0.4, 0.3, 0.12)).norm(), 0.05, 1e-9);  // the depth formula's
}

// --- simulated motion: three unsynchronised cameras at 30 fps, a marker at 1 m/s -----------

struct Delivered {
  std::int64_t arrival;
  FrameObservations batch;
};

// A marker on a circle of radius 1 m at 1 m/s, seen by 3 cameras at 30 fps with capture
// epochs 0/11/23 ms and 1.5 mm of noise per coordinate; each frame reaches the fusion one
// frame period + 4..12 ms of processing after its capture, camera `slow` `slow_extra` later.
std::vector<Delivered> circle_frames(double seconds, int slow, std::int64_t slow_extra, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.0015);
  std::uniform_int_distribution<std::int64_t> processing(4 * kMs, 12 * kMs);
  const std::int64_t epochs[3] = {0, 11 * kMs, 23 * kMs};
  const double period = 1.0 / 30.0;
  std::vector<Delivered> frames;
  for (int cam = 0; cam < 3; ++cam) {
    for (int k = 0; k * period < seconds; ++k) {
      const std::int64_t t = epochs[cam] + std::llround(k * period * 1e9);
      const double a = 1e-9 * static_cast<double>(t);  // 1 m/s on radius 1 m: angle = time
      const Eigen::Vector3d p(std::cos(a) + noise(rng), std::sin(a) + noise(rng), 0.1);
      std::int64_t arrival = t + std::llround(period * 1e9) + processing(rng);
      if (cam == slow) arrival += slow_extra;
      frames.push_back({arrival, frame(cam, t, {obs(1, cam, t, p)})});
    }
  }
  std::stable_sort(frames.begin(), frames.end(),
                   [](const Delivered& x, const Delivered& y) { return x.arrival < y.arrival; });
  return frames;
}

double circle_error(const Eigen::Vector3d& p, std::int64_t t) {
  const double a = 1e-9 * static_cast<double>(t);
  return std::hypot(p.x() - std::cos(a), p.y() - std::sin(a));
}

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(v.size()))) - 1];
}

TEST(TrackFusion, MovingMarkerUnsynchronisedCamerasBeatsFrameSetFusion) {
  const auto frames = circle_frames(10.0, -1, 0, 7);
  // New: every frame's record, error against the truth at the record's capture time.
  TrackFusion f;
  std::vector<double> fresh;
  std::vector<FusedMarker> out;
  for (const auto& d : frames) {
    out.clear();
    f.add(d.batch, mean(), &out);
    for (const auto& m : out)
      if (m.t_mono_ns > 200 * kMs) fresh.push_back(circle_error(m.p_world, m.t_mono_ns));
  }
  // Old: frame sets (window 20 ms, all three cameras expected, max_wait 50 ms), the record's time
  // = header time (newest frame) + dt_us (weighted mean of the frames' times), or the header alone.
  FrameGrouper g(20 * kMs, 50 * kMs);
  g.set_expected_cameras({0, 1, 2});
  std::vector<std::vector<FrameObservations>> done;
  std::vector<double> old_record, old_header;
  for (const auto& d : frames) g.add(d.batch, d.arrival, done);
  for (const auto& set : done) {
    std::vector<WorldObservation> all;
    std::int64_t newest = 0;
    for (const auto& b : set) {
      all.insert(all.end(), b.observations.begin(), b.observations.end());
      newest = std::max(newest, b.t_mono_ns);
    }
    for (const auto& m : fuse(all, mean())) {
      if (m.t_mono_ns <= 200 * kMs) continue;
      old_record.push_back(circle_error(m.p_world, m.t_mono_ns));
      old_header.push_back(circle_error(m.p_world, newest));
    }
  }
  std::printf(
      "[ fusion  ] 1 m/s, epochs 0/11/23 ms, 1.5 mm noise: error p95 asynchronous %.2f mm (%zu records), "
      "frame sets %.2f mm at the record's time / %.2f mm at the header's time (%zu records)\n",
      1e3 * p95(fresh), fresh.size(), 1e3 * p95(old_record), 1e3 * p95(old_header), old_record.size());
  EXPECT_LE(p95(fresh), 0.010);
  // One record per frame (after the first 200 ms), not one per set of about two frames.
  EXPECT_GE(static_cast<double>(fresh.size()), 0.97 * static_cast<double>(frames.size()));
  EXPECT_GT(static_cast<double>(fresh.size()), 1.8 * static_cast<double>(old_record.size()));
  EXPECT_LT(p95(fresh), p95(old_header));
  EXPECT_LE(p95(fresh), 1.05 * p95(old_record));  // extrapolating costs no accuracy against averaging
}

TEST(TrackFusion, ASlowCameraNeverMakesAMarkersTimeGoBack) {
  for (std::int64_t extra : {25 * kMs, 80 * kMs}) {
    const auto frames = circle_frames(5.0, 2, extra, 11);
    TrackFusion f;
    std::vector<FusedMarker> out;
    std::int64_t last = -1;
    std::uint32_t masks = 0;
    std::vector<double> errors;
    for (const auto& d : frames) {
      out.clear();
      f.add(d.batch, mean(), &out);
      for (const auto& m : out) {
        ASSERT_GE(m.t_mono_ns, last) << "extra delay " << extra / kMs << " ms";
        last = m.t_mono_ns;
        masks |= m.camera_mask;
        if (m.t_mono_ns > 200 * kMs) errors.push_back(circle_error(m.p_world, m.t_mono_ns));
      }
    }
    EXPECT_GT(f.counters().late, 100u);  // most of the slow camera's frames arrive after newer ones
    EXPECT_LE(p95(errors), 0.010);
    // 25 ms late: still within the 50 ms window of the others' frames, so it contributes.
    if (extra == 25 * kMs) {
      EXPECT_EQ(masks, 0b111u);
    }
  }
}

}  // namespace
}  // namespace ips
