#include "fusion_worker.h"

#include <pthread.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <spdlog/spdlog.h>

#include "ips/clock.h"

namespace ipsd {

namespace {
// Longest wait for a batch: bounds the heartbeat period and the time to notice a stop.
constexpr std::int64_t kPopTimeoutNs = 100'000'000;

ips::TrackFusionOptions fusion_options(const ips::FusionConfig& c) {
  ips::TrackFusionOptions o;
  o.window_s = c.window_s;
  o.velocity_span_s = c.velocity_span_s;
  o.history_s = c.history_s;
  o.single_camera_depth = c.single_camera_depth;
  o.kalman = c.kalman;
  o.kalman_options = c.kalman_options;
  return o;
}

// The fixed markers' surveyed positions (markers.ids.<id>.fixed) and the check's threshold.
std::map<int, Eigen::Vector3d> fixed_positions(const ips::MarkerConfig& m) {
  std::map<int, Eigen::Vector3d> out;
  for (const auto& [id, info] : m.ids)
    if (info.fixed) out[id] = Eigen::Vector3d((*info.fixed)[0], (*info.fixed)[1], (*info.fixed)[2]);
  return out;
}

ips::FixedMarkerMonitor::Options monitor_options(const ips::FusionConfig& c) {
  ips::FixedMarkerMonitor::Options o;
  o.warn_m = c.fixed_marker_warn_m;
  return o;
}

void log_events(const std::vector<ips::FixedMarkerEvent>& events, const ips::DaemonConfig& config) {
  for (const auto& e : events) {
    const std::string& camera = config.cameras.at(static_cast<std::size_t>(e.camera_index)).name;
    if (e.kind == ips::FixedMarkerEvent::Kind::kMoved)
      spdlog::warn("camera '{}' may have moved: fixed marker {} seen {:.1f} cm from its surveyed position", camera,
                   e.id, 100 * e.error_m);
    else
      spdlog::info("camera '{}': fixed marker {} back to {:.1f} cm from its surveyed position", camera, e.id,
                   100 * e.error_m);
  }
}

bool same_options(const ips::TrackFusionOptions& a, const ips::TrackFusionOptions& b) {
  return a.window_s == b.window_s && a.velocity_span_s == b.velocity_span_s && a.history_s == b.history_s &&
         a.single_camera_depth == b.single_camera_depth &&
         a.kalman == b.kalman && a.kalman_options.process_noise == b.kalman_options.process_noise &&
         a.kalman_options.measurement_noise == b.kalman_options.measurement_noise &&
         a.kalman_options.reset_after_s == b.kalman_options.reset_after_s &&
         a.kalman_options.initial_velocity_std == b.kalman_options.initial_velocity_std;
}
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
  ips::TrackFusion fusion(fusion_options(rt->config.fusion));
  std::uint64_t counted_late = 0, counted_too_old = 0;
  std::int64_t next_tick = 0;  // fixed-rate output: next publish time, CLOCK_MONOTONIC
  std::vector<ips::FusedMarker> states;
  if (fixed_) fixed_->configure(fixed_positions(rt->config.markers), monitor_options(rt->config.fusion));

  while (!stop_) {
    const std::int64_t now = ips::monotonic_ns();
    stats_.heartbeat_ns = now;
    // A reload may change the fusion options, the method or the outputs. Tracks (and with them
    // the order guarantee) survive a reload unless the fusion options changed.
    if (auto latest = runtime_.get(); latest != rt) {
      if (!same_options(fusion_options(latest->config.fusion), fusion.options())) {
        stats_.late += fusion.counters().late - counted_late;
        stats_.too_old += fusion.counters().too_old - counted_too_old;
        counted_late = counted_too_old = 0;
        ips::TrackFusion fresh(fusion_options(latest->config.fusion));
        fresh.continue_after(fusion);
        fusion = std::move(fresh);
      }
      rt = latest;
      if (fixed_) fixed_->configure(fixed_positions(rt->config.markers), monitor_options(rt->config.fusion));
    }
    const double rate = rt->config.fusion.output_rate_hz;
    const auto period = rate > 0 ? static_cast<std::int64_t>(std::llround(1e9 / rate)) : 0;
    if (period > 0 && next_tick == 0) next_tick = now + period;
    if (period == 0) next_tick = 0;

    const std::int64_t wait =
        period > 0 ? std::clamp<std::int64_t>(next_tick - now, 0, kPopTimeoutNs) : kPopTimeoutNs;
    ips::FrameObservations batch;
    if (queue_.pop(batch, wait)) {
      // Each camera's own view of the fixed markers, before fusion mixes the cameras.
      if (fixed_ && !fixed_->empty()) log_events(fixed_->add(batch), rt->config);
      states.clear();
      fusion.add(batch, *rt->fusion, period > 0 ? nullptr : &states);
      if (period == 0) publish(states, batch.t_mono_ns, batch.t_real_ns, batch.t_delivered_ns, *rt);
    }
    if (period > 0 && ips::monotonic_ns() >= next_tick) {
      // Fixed rate: every marker's state predicted to the publish instant.
      const std::int64_t t = ips::monotonic_ns();
      states.clear();
      fusion.predict_all(t, t + ips::realtime_minus_monotonic_ns(), *rt->fusion, states);
      publish(states, t, t + ips::realtime_minus_monotonic_ns(), 0, *rt);
      next_tick = std::max(next_tick + period, t);
    }
    stats_.late += fusion.counters().late - counted_late;
    stats_.too_old += fusion.counters().too_old - counted_too_old;
    counted_late = fusion.counters().late;
    counted_too_old = fusion.counters().too_old;
  }
}

void FusionWorker::publish(const std::vector<ips::FusedMarker>& states, std::int64_t t_mono_ns, std::int64_t t_real_ns,
                           std::int64_t t_delivered_ns, const Runtime& rt) {
  ips::Datagram d;
  d.capture_monotonic_ns = t_mono_ns;  // per-frame: the frame's capture time; fixed rate: the prediction time
  d.capture_realtime_ns = t_real_ns;
  d.update = update_++;
  d.has_velocity = rt.config.fusion.kalman;
  for (const ips::FusedMarker& f : states) {
    // The one place every output (UDP, ROS 2, MAVLink, subscriptions, web) gets markers from:
    // markers with publish: false (fixed references by default) stop here.
    if (!rt.config.markers.published(f.id)) continue;
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
    m.covariance = {f.covariance(0, 0), f.covariance(0, 1), f.covariance(0, 2),
                    f.covariance(1, 1), f.covariance(1, 2), f.covariance(2, 2)};
    d.markers.push_back(m);
  }
  rt.publisher->publish(d);
  if (web_) web_->publish(d);  // a copy into a bounded inbox; never waits for browsers
  const std::int64_t sent = ips::monotonic_ns();  // after the last sendto of the update
  if (t_delivered_ns > 0) stats_.latency.add(sent - t_delivered_ns, sent - t_mono_ns);
  ++stats_.updates;
  stats_.last_latency_ns = rt.publisher->last_latency_ns();
  std::lock_guard lock(stats_.outputs_mutex);
  stats_.outputs = rt.publisher->stats();
}

}  // namespace ipsd
