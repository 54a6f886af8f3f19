// fusion.camera_hold follows how late the cameras' frames reach fusion (ips/fusion/camera_lag.h):
// the lag's sliding maximum by hand, and a range fix of a robot the camera saw held for the
// camera's record even when that camera's frames arrive 0.8 s late (a starved machine).
#include <gtest/gtest.h>

#include "ips/fusion/camera_lag.h"
#include "ips/fusion/track_fusion.h"
#include "ips/ranging/multilateration.h"
#include "ips/ranging/range_observation.h"

namespace ips {
namespace {

constexpr std::int64_t kMsNs = 1'000'000;

TEST(CameraLag, TheLargestLagOfTheLastFiveSeconds) {
  CameraLag lag;
  EXPECT_EQ(lag.max_ns(), 0);
  lag.add(0, 40 * kMsNs);               // 40 ms
  lag.add(1000 * kMsNs, 1300 * kMsNs);  // 300 ms
  lag.add(2000 * kMsNs, 2050 * kMsNs);  // 50 ms
  EXPECT_EQ(lag.max_ns(), 300 * kMsNs);
  lag.add(6000 * kMsNs, 6020 * kMsNs);  // the 300 ms one arrived at 1.3 s: still within 5 s
  EXPECT_EQ(lag.max_ns(), 300 * kMsNs);
  lag.add(6400 * kMsNs, 6420 * kMsNs);  // now it is 5.1 s old: the 50 ms one is the largest left
  EXPECT_EQ(lag.max_ns(), 50 * kMsNs);
  lag.add(7000 * kMsNs, 6900 * kMsNs);  // a clock that goes back: ignored
  EXPECT_EQ(lag.max_ns(), 50 * kMsNs);
}

WorldObservation seen_at(int id, int stream, ObservationSource source, std::int64_t t, double x) {
  if (source == ObservationSource::kRanges) {
    RangeFix fix;
    fix.ok = true;
    fix.position = {x, 0.0, 0.1};
    fix.covariance = 25e-4 * Eigen::Matrix3d::Identity();
    return range_fix_observation(fix, id, stream, t, t);
  }
  WorldObservation o;
  o.id = id;
  o.camera_index = stream;
  o.p_world = {x, 0.0, 0.1};
  o.area_px = 900;
  o.t_mono_ns = t;
  o.t_real_ns = t;
  return o;
}

// A robot at 0.2 m/s under one camera (10 fps) whose frames reach fusion `camera_lag_ms` after
// capture, ranging at 10 Hz with its fixes there 10 ms after the firing. How many range fixes
// published a record of their own (each one a camera record made late and lost).
int range_records(std::int64_t camera_lag_ms, double& hold_s) {
  TrackFusion fusion;  // camera_hold 0.5 s
  const FusionMethod& mean = find_fusion_method("mean", "");
  struct Arrival {
    std::int64_t at;
    FrameObservations batch;
  };
  std::vector<Arrival> arrivals;
  for (int i = 0; i < 100; ++i) {
    const std::int64_t t = 1000 * kMsNs + i * 100 * kMsNs;
    const double x = 0.02 * i;
    FrameObservations camera;
    camera.camera_index = 0;
    camera.t_mono_ns = camera.t_real_ns = t;
    camera.observations = {seen_at(5, 0, ObservationSource::kCamera, t, x)};
    arrivals.push_back({t + camera_lag_ms * kMsNs, camera});
    FrameObservations range;
    range.camera_index = -1;
    range.t_mono_ns = range.t_real_ns = t;
    range.observations = {seen_at(5, 7, ObservationSource::kRanges, t, x + 0.03)};
    arrivals.push_back({t + 10 * kMsNs, range});
  }
  std::stable_sort(arrivals.begin(), arrivals.end(), [](const Arrival& a, const Arrival& b) { return a.at < b.at; });
  int from_ranges = 0;
  for (Arrival& a : arrivals) {
    a.batch.t_fusion_ns = a.at;
    std::vector<FusedMarker> out;
    fusion.add(a.batch, mean, &out);
    for (const FusedMarker& f : out)
      if (f.camera_mask == 0) ++from_ranges;
  }
  hold_s = fusion.effective_camera_hold_s();
  return from_ranges;
}

TEST(CameraHold, FollowsHowLateTheCamerasFramesArrive) {
  double hold = 0;
  // 80 ms late (a quiet machine): within the configured 0.5 s; one range record before the first frame.
  EXPECT_EQ(range_records(80, hold), 1);
  EXPECT_DOUBLE_EQ(hold, 0.5);
  // 800 ms late (a starved camera): the hold grows to 1.5 x 0.8 s and the ranges still wait
  // for the camera's records (with a fixed 0.5 s hold each one would publish first, and every
  // camera record after it be late).
  EXPECT_EQ(range_records(800, hold), 8);
  EXPECT_NEAR(hold, 1.2, 1e-9);
}

}  // namespace
}  // namespace ips
