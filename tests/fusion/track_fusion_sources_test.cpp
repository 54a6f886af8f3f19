// Fusion of sources other than the cameras (ips/fusion/track_fusion.h): range fixes weighed by
// their covariance against hand-computed means, and a robot that drives out of every camera's
// view and back, against the simulated truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>

#include "ips/fusion/track_fusion.h"
#include "ips/ranging/multilateration.h"
#include "ips/ranging/range_observation.h"

namespace ips {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kRealOffset = 1'000'000'000'000;

const FusionMethod& mean() { return find_fusion_method("mean", ""); }

WorldObservation camera_obs(int id, int cam, std::int64_t t, const Eigen::Vector3d& p, double yaw) {
  WorldObservation o;
  o.id = id;
  o.camera_index = cam;
  o.p_world = p;
  o.yaw = yaw;
  o.area_px = 900.0;
  o.t_mono_ns = t;
  o.t_real_ns = t + kRealOffset;
  return o;
}

WorldObservation range_obs(int id, int tag, std::int64_t t, const Eigen::Vector3d& p, const Eigen::Matrix3d& cov) {
  RangeFix fix;
  fix.ok = true;
  fix.position = p;
  fix.covariance = cov;
  return range_fix_observation(fix, id, tag, t, t + kRealOffset);
}

FrameObservations batch(int index, std::int64_t t, std::vector<WorldObservation> o) {
  FrameObservations b;
  b.camera_index = index;
  b.t_mono_ns = t;
  b.t_real_ns = t + kRealOffset;
  b.observations = std::move(o);
  return b;
}

TEST(TrackFusionSources, RangeFixesAreCombinedByTheirCovariances) {
  // Two tags' fixes of one robot at one instant: (0, 0) with variances (1, 4) cm^2 and (1, 1)
  // with (4, 1) cm^2. Information-weighted: x = (0/1 + 1/4) / (1/1 + 1/4) = 0.2, y = 0.8; the
  // variance of each axis 1 / (1/1 + 1/4) = 0.8 cm^2.
  TrackFusion f;
  std::vector<FusedMarker> out;
  const Eigen::Matrix3d a = Eigen::Vector3d(1e-4, 4e-4, 1e-4).asDiagonal();
  const Eigen::Matrix3d b = Eigen::Vector3d(4e-4, 1e-4, 1e-4).asDiagonal();
  f.add(batch(0, 100 * kMs, {range_obs(7, 1, 100 * kMs, {0, 0, 0}, a), range_obs(7, 2, 100 * kMs, {1, 1, 0}, b)}),
        mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].p_world.x(), 0.2, 1e-4);
  EXPECT_NEAR(out[0].p_world.y(), 0.8, 1e-4);
  EXPECT_NEAR(out[0].p_world.z(), 0.0, 1e-9);
  EXPECT_NEAR(out[0].covariance(0, 0), 0.8e-4, 1e-7);
  EXPECT_NEAR(out[0].covariance(1, 1), 0.8e-4, 1e-7);
  EXPECT_EQ(out[0].camera_mask, 0u) << "a tag is not a camera";
  EXPECT_EQ(out[0].sources, source_bit(ObservationSource::kRanges));
  EXPECT_FALSE(out[0].has_yaw);
  EXPECT_EQ(out[0].t_mono_ns, 100 * kMs);
}

TEST(TrackFusionSources, ARangeFixBarelyMovesWhatACameraSees) {
  // Camera 0 sees the robot at x = 1; a range fix 5 cm off (sigma 5 cm) at the same instant.
  // Camera sigma 2 mm: x = 1 + 0.05 * 0.002^2 / (0.002^2 + 0.05^2) = 1.00008.
  TrackFusion f;
  std::vector<FusedMarker> out;
  f.add(batch(0, 0,
              {camera_obs(3, 0, 0, {1.0, 2.0, 0.1}, 0.5),
               range_obs(3, 9, 0, {1.05, 2.0, 0.1}, 25e-4 * Eigen::Matrix3d::Identity())}),
        mean(), &out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].p_world.x(), 1.0 + 0.05 * 4e-6 / (4e-6 + 25e-4), 1e-6);
  EXPECT_NEAR(out[0].p_world.y(), 2.0, 1e-9);
  EXPECT_EQ(out[0].camera_mask, 1u);
  EXPECT_EQ(out[0].sources, source_bit(ObservationSource::kCamera) | source_bit(ObservationSource::kRanges));
  EXPECT_TRUE(out[0].has_yaw);
  EXPECT_NEAR(out[0].yaw, 0.5, 1e-12) << "the heading is the camera's alone";
}

// The hand-over: a robot on a circle (r 0.45 m, 0.2 m/s) seen by two unsynchronised
// cameras (30 fps, 1 mm noise) except from 5 s to 25 s, ranging to 4 anchors at three heights
// (UWB-like 5 cm sigma) at 10 Hz; each fix arrives 50 ms after its firing.
struct HandOverRun {
  std::vector<FusedMarker> records;
  std::vector<Eigen::Vector3d> truth;  // at each record's time
};

Eigen::Vector3d circle(double t) {
  const double w = 0.2 / 0.45;
  return {2.0 + 0.45 * std::cos(w * t), 1.5 + 0.45 * std::sin(w * t), 0.1};
}
double heading(double t) { return 0.2 / 0.45 * t + M_PI / 2; }
bool in_view(double t) { return t < 5.0 || t >= 25.0; }
double seconds(std::int64_t t) { return 1e-9 * static_cast<double>(t); }

HandOverRun drive(bool with_ranges) {
  struct Event {
    std::int64_t arrival, t;
    int source;  // 0, 1: cameras; 2: ranges
  };
  std::vector<Event> events;
  for (std::int64_t t = 0; t < 30'000 * kMs; t += 33'333'333) {
    if (!in_view(seconds(t))) continue;
    events.push_back({t + 33 * kMs, t, 0});
    events.push_back({t + 11 * kMs + 33 * kMs, t + 11 * kMs, 1});
  }
  if (with_ranges)
    for (std::int64_t t = 3 * kMs; t < 30'000 * kMs; t += 100 * kMs) events.push_back({t + 50 * kMs, t, 2});
  std::sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.arrival < b.arrival; });

  const std::vector<Eigen::Vector3d> anchors = {{0, 0, 2.5}, {4, 0, 2.0}, {4, 3, 2.5}, {0, 3, 1.5}};
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  RangeSolveOptions at_floor;
  at_floor.known_height = 0.1;
  TrackFusion fusion;
  HandOverRun run;
  for (const Event& e : events) {
    const Eigen::Vector3d p = circle(seconds(e.t));
    std::vector<FusedMarker> out;
    if (e.source < 2) {
      const Eigen::Vector3d seen = p + 0.001 * Eigen::Vector3d(noise(rng), noise(rng), 0.0);
      fusion.add(batch(e.source, e.t, {camera_obs(4, e.source, e.t, seen, heading(seconds(e.t)))}), mean(), &out);
    } else {
      std::vector<RangeToAnchor> ranges;
      for (const auto& a : anchors) ranges.push_back({a, (a - p).norm() + 0.05 * noise(rng), 0.05});
      const RangeFix fix = fix_least_squares(ranges, at_floor);
      EXPECT_TRUE(fix.ok) << fix.why;
      if (!fix.ok) continue;
      fusion.add(batch(0, e.t, {range_fix_observation(fix, 4, 1, e.t, e.t + kRealOffset)}), mean(), &out);
    }
    for (const auto& f : out) {
      run.records.push_back(f);
      run.truth.push_back(circle(seconds(f.t_mono_ns)));
    }
  }
  return run;
}

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[static_cast<std::size_t>(0.95 * static_cast<double>(v.size() - 1))];
}

TEST(TrackFusionSources, ARobotOutOfEveryCamerasViewIsPublishedFromRangesAndHandedBackWithoutAJump) {
  const HandOverRun cameras_only = drive(false), both = drive(true);
  std::vector<double> inside, inside_cameras_only, outside;
  for (std::size_t i = 0; i < cameras_only.records.size(); ++i)
    inside_cameras_only.push_back((cameras_only.records[i].p_world - cameras_only.truth[i]).head<2>().norm());
  const std::uint16_t ranges_only = source_bit(ObservationSource::kRanges);
  std::size_t first_outside = 0, first_back = 0;
  for (std::size_t i = 0; i < both.records.size(); ++i) {
    const FusedMarker& f = both.records[i];
    const double e = (f.p_world - both.truth[i]).head<2>().norm();
    if (i > 0) {
      EXPECT_GE(f.t_mono_ns, both.records[i - 1].t_mono_ns) << "back in time at record " << i;
    }
    if (f.camera_mask) {
      inside.push_back(e);
      EXPECT_TRUE(f.has_yaw);
      if (first_outside && !first_back) first_back = i;
    } else {
      ASSERT_EQ(f.sources, ranges_only) << "record " << i;
      EXPECT_FALSE(f.has_yaw);
      // Ranges alone where no camera has seen the robot for 100 ms (a fix just after the cameras
      // see it again has no camera estimate of its own instant to meet).
      EXPECT_FALSE(in_view(seconds(f.t_mono_ns) - 0.1)) << "ranges alone at " << seconds(f.t_mono_ns) << " s";
      outside.push_back(e);
      if (!first_outside) first_outside = i;
    }
  }
  ASSERT_GT(first_outside, 0u);
  ASSERT_GT(first_back, first_outside);
  std::printf(
      "[ sources ] 2-D error p95: inside the cameras' view %.2f mm (cameras alone %.2f mm, %zu records), "
      "from ranges alone %.1f mm (%zu records)\n",
      1e3 * p95(inside), 1e3 * p95(inside_cameras_only), inside.size(), 1e3 * p95(outside), outside.size());
  EXPECT_LE(p95(inside), p95(inside_cameras_only) + 0.0001) << "the ranges must not pull the cameras' positions";
  EXPECT_LE(p95(outside), 0.10);
  EXPECT_GE(outside.size(), 190u) << "a fix every 100 ms for 20 s";

  // The hand-overs: the step between consecutive records beyond the truth's own motion is
  // within 3 sigma of the range fix (its stated covariance, the larger horizontal axis).
  for (const std::size_t i : {first_outside, first_back}) {
    const FusedMarker &before = both.records[i - 1], &after = both.records[i];
    const FusedMarker& fix = after.camera_mask ? before : after;
    const Eigen::Matrix2d cov = fix.covariance.topLeftCorner<2, 2>();
    const double sigma = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues().maxCoeff());
    const Eigen::Vector2d jump =
        (after.p_world - before.p_world).head<2>() - (both.truth[i] - both.truth[i - 1]).head<2>();
    EXPECT_LE(jump.norm(), 3 * sigma) << "at " << seconds(after.t_mono_ns) << " s, sigma " << sigma;
    EXPECT_GT(sigma, 0.005) << "a 5 cm range fix does not claim mm accuracy";
  }
  // The heading is held from the last camera record through the ranges alone.
  EXPECT_NEAR(both.records[first_outside].yaw, both.records[first_outside - 1].yaw, 1e-12);
}

}  // namespace
}  // namespace ips
