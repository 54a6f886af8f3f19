#include "fusion_worker.h"

#include <pthread.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include "ips/clock.h"
#include "ips/kalman.h"

namespace ipsd {

namespace {
// Longest wait for a batch: bounds the heartbeat period and the time to notice a stop.
constexpr std::int64_t kPopTimeoutNs = 100'000'000;
}  // namespace

FusionWorker::FusionWorker(RuntimeHolder& runtime, ObservationQueue& queue, std::vector<CameraStats*> cameras,
                           FusionStats& stats)
    : runtime_(runtime), queue_(queue), cameras_(std::move(cameras)), stats_(stats) {}

FusionWorker::~FusionWorker() {
  request_stop();
  join();
}

void FusionWorker::start() {
  stats_.heartbeat_ns = ips::monotonic_ns();
  thread_ = std::thread([this] { run(); });
}

void FusionWorker::join() {
  if (thread_.joinable()) thread_.join();
}

void FusionWorker::run() {
  pthread_setname_np(pthread_self(), "fusion");
  std::shared_ptr<const Runtime> rt = runtime_.get();
  auto make_grouper = [](const Runtime& r) {
    return ips::FrameGrouper(static_cast<std::int64_t>(r.config.fusion.window_s * 1e9),
                             static_cast<std::int64_t>(r.config.fusion.max_wait_s * 1e9));
  };
  ips::FrameGrouper grouper = make_grouper(*rt);
  if (rt->config.fusion.kalman) tracker_.emplace(rt->config.fusion.kalman_options);
  std::vector<std::vector<ips::FrameObservations>> done;

  while (!stop_) {
    const std::int64_t now = ips::monotonic_ns();
    stats_.heartbeat_ns = now;
    // A reload may change the window, the method, the filter or the outputs.
    if (auto latest = runtime_.get(); latest != rt) {
      grouper.poll(std::numeric_limits<std::int64_t>::max(), done);  // flush with the old settings
      for (auto& set : done) publish(set, *rt);
      done.clear();
      if (latest->config.fusion.window_s != rt->config.fusion.window_s ||
          latest->config.fusion.max_wait_s != rt->config.fusion.max_wait_s)
        grouper = make_grouper(*latest);
      if (!latest->config.fusion.kalman) {
        tracker_.reset();
      } else if (!tracker_ ||
                 latest->config.fusion.kalman_options.process_noise != rt->config.fusion.kalman_options.process_noise ||
                 latest->config.fusion.kalman_options.measurement_noise != rt->config.fusion.kalman_options.measurement_noise ||
                 latest->config.fusion.kalman_options.reset_after_s != rt->config.fusion.kalman_options.reset_after_s ||
                 latest->config.fusion.kalman_options.initial_velocity_std != rt->config.fusion.kalman_options.initial_velocity_std) {
        tracker_.emplace(latest->config.fusion.kalman_options);
      }
      rt = latest;
    }
    // A set is complete once every camera that is currently delivering is in it.
    std::set<int> expected;
    for (std::size_t i = 0; i < cameras_.size(); ++i)
      if (cameras_[i]->state == static_cast<int>(CameraState::kOpen)) expected.insert(static_cast<int>(i));
    grouper.set_expected_cameras(std::move(expected));

    const std::int64_t deadline = grouper.deadline_ns();
    const std::int64_t wait = deadline < 0 ? kPopTimeoutNs : std::clamp<std::int64_t>(deadline - now, 0, kPopTimeoutNs);
    ips::FrameObservations batch;
    if (queue_.pop(batch, wait)) {
      grouper.add(std::move(batch), ips::monotonic_ns(), done);
    } else {
      grouper.poll(ips::monotonic_ns(), done);
    }
    for (auto& set : done) publish(set, *rt);
    done.clear();
  }
}

void FusionWorker::publish(std::vector<ips::FrameObservations>& set, const Runtime& rt) {
  std::vector<ips::WorldObservation> all;
  ips::Datagram d;
  d.capture_monotonic_ns = std::numeric_limits<std::int64_t>::min();
  for (const auto& b : set) {
    all.insert(all.end(), b.observations.begin(), b.observations.end());
    if (b.t_mono_ns > d.capture_monotonic_ns) {  // the update carries its newest frame's time
      d.capture_monotonic_ns = b.t_mono_ns;
      d.capture_realtime_ns = b.t_real_ns;
    }
  }
  d.update = update_++;
  d.has_velocity = tracker_.has_value();
  for (ips::FusedMarker& f : ips::fuse(all, *rt.fusion)) {
    if (tracker_) tracker_->update(f);
    ips::MarkerRecord m;
    m.id = static_cast<std::uint32_t>(f.id);
    m.camera_mask = f.camera_mask;
    m.x = f.p_world.x();
    m.y = f.p_world.y();
    m.z = f.p_world.z();
    m.yaw = f.yaw;
    m.quality = f.quality;
    m.spread = f.spread;
    m.dt_us = static_cast<std::int32_t>(
        std::clamp<std::int64_t>((f.t_mono_ns - d.capture_monotonic_ns) / 1000, -1'000'000'000, 0));
    m.vx = f.velocity.x();
    m.vy = f.velocity.y();
    m.vz = f.velocity.z();
    d.markers.push_back(m);
  }
  rt.publisher->publish(d);
  ++stats_.updates;
  stats_.last_latency_ns = rt.publisher->last_latency_ns();
  std::lock_guard lock(stats_.outputs_mutex);
  stats_.outputs = rt.publisher->stats();
}

}  // namespace ipsd
