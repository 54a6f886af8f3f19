#include "fusion_worker.h"

#include <pthread.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"
#include "ips/output/wire.h"

static_assert(ips::source_bit(ips::ObservationSource::kCamera) == IPS_WIRE_SOURCE_CAMERA &&
                  ips::source_bit(ips::ObservationSource::kRanges) == IPS_WIRE_SOURCE_RANGES &&
                  ips::source_bit(ips::ObservationSource::kInsideOut) == IPS_WIRE_SOURCE_INSIDE_OUT,
              "the wire's source bits are the fusion's");

namespace ipsd {

namespace {
// Longest wait for a batch: bounds the heartbeat period and the time to notice a stop.
constexpr std::int64_t kPopTimeoutNs = 100'000'000;

// The fusion's own options are the base of the configuration's section.
const ips::TrackFusionOptions& fusion_options(const ips::FusionConfig& c) { return c; }

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

ips::BodyTrackOptions body_options(const ips::FusionConfig& c) {
  ips::BodyTrackOptions o;
  static_cast<ips::FusionTimeWindows&>(o) = c;
  o.camera_sigma_m = c.camera_sigma_m;
  o.between_cameras_process_noise = c.between_cameras_process_noise;
  return o;
}

// A reload rebuilds the body fusion only when the bodies or the options it uses changed.
bool same_bodies(const std::vector<ips::BodyDef>& a, const std::vector<ips::BodyDef>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].name != b[i].name || a[i].ground != b[i].ground || a[i].markers.size() != b[i].markers.size())
      return false;
    for (std::size_t k = 0; k < a[i].markers.size(); ++k) {
      const auto &x = a[i].markers[k], &y = b[i].markers[k];
      if (x.id != y.id || x.edge != y.edge || x.plate != y.plate || x.position != y.position || x.axes != y.axes)
        return false;
    }
  }
  return true;
}

std::optional<ips::BodyTrack> make_body_track(const ips::DaemonConfig& c) {
  if (c.bodies.empty()) return std::nullopt;
  return ips::BodyTrack(c.bodies, body_options(c.fusion));
}

// A record's time relative to its datagram's header (wire.h: dt_us <= 0).
std::int32_t dt_us(std::int64_t record_ns, std::int64_t header_ns) {
  return static_cast<std::int32_t>(std::clamp<std::int64_t>((record_ns - header_ns) / 1000, -1'000'000'000, 0));
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
  std::uint64_t counted_late = 0, counted_too_old = 0, counted_held = 0;
  std::int64_t next_tick = 0;  // fixed-rate output: next publish time, CLOCK_MONOTONIC
  std::vector<ips::FusedMarker> states;
  std::optional<ips::BodyTrack> bodies = make_body_track(rt->config);  // docs/bodies.md
  std::uint64_t counted_body_late = 0, counted_body_held = 0;
  std::vector<ips::FusedBody> body_states;
  if (fixed_) fixed_->configure(fixed_positions(rt->config.markers), monitor_options(rt->config.fusion));

  while (!stop_) {
    const std::int64_t now = ips::monotonic_ns();
    stats_.heartbeat_ns = now;
    // A reload may change the fusion options, the method or the outputs. Tracks (and with them
    // the order guarantee) survive a reload unless the fusion options changed.
    if (auto latest = runtime_.get(); latest != rt) {
      if (fusion_options(latest->config.fusion) != fusion.options()) {
        stats_.late += fusion.counters().late - counted_late;
        stats_.too_old += fusion.counters().too_old - counted_too_old;
        stats_.held_for_cameras += fusion.counters().held_for_cameras - counted_held;
        counted_late = counted_too_old = counted_held = 0;
        ips::TrackFusion fresh(fusion_options(latest->config.fusion));
        fresh.continue_after(fusion);
        fusion = std::move(fresh);
      }
      const auto& old_c = rt->config;
      const auto& new_c = latest->config;
      if (!same_bodies(old_c.bodies, new_c.bodies) || body_options(old_c.fusion) != body_options(new_c.fusion)) {
        if (bodies) {
          stats_.late += bodies->late() - counted_body_late;
          stats_.held_for_cameras += bodies->held_for_cameras() - counted_body_held;
        }
        counted_body_late = counted_body_held = 0;
        auto fresh = make_body_track(new_c);
        if (fresh && bodies) fresh->continue_after(*bodies);
        bodies = std::move(fresh);
      }
      rt = latest;
      if (fixed_) fixed_->configure(fixed_positions(rt->config.markers), monitor_options(rt->config.fusion));
    }
    const double rate = rt->config.fusion.output_rate_hz;
    const auto period = rate > 0 ? static_cast<std::int64_t>(std::llround(1e9 / rate)) : 0;
    if (period > 0 && next_tick == 0) next_tick = now + period;
    if (period == 0) next_tick = 0;

    const std::int64_t wait = period > 0 ? std::clamp<std::int64_t>(next_tick - now, 0, kPopTimeoutNs) : kPopTimeoutNs;
    CameraBatch batch;
    if (queue_.pop(batch, wait)) {
      batch.t_fusion_ns = ips::monotonic_ns();  // how late camera frames arrive: fusion.camera_hold follows it
      // Each camera's own view of the fixed markers, before fusion mixes the cameras.
      if (fixed_ && !fixed_->empty() && batch.camera_index >= 0) log_events(fixed_->add(batch), rt->config);
      states.clear();
      fusion.add(batch, *rt->fusion, period > 0 ? nullptr : &states);
      body_states.clear();
      if (bodies && !batch.bodies.empty() && batch.camera_index >= 0)
        bodies->add(batch.camera_index, batch.t_mono_ns, batch.t_real_ns, batch.bodies, *rt->fusion, body_states);
      if (bodies)  // ranging tags on bodies (ranging.tags[].body)
        for (const BodyFix& b : batch.body_fixes)
          bodies->add_fix(b.body, b.offset, b.fix, fusion.effective_camera_hold_s(), body_states);
      if (period == 0) publish(states, body_states, batch.t_mono_ns, batch.t_real_ns, batch.t_delivered_ns, *rt);
    }
    if (const std::int64_t woke = ips::monotonic_ns(); period > 0 && woke >= next_tick) {
      // Fixed rate: every marker's state predicted to the tick, an instant of an exact grid
      // (period apart), whenever this thread got to run: a starved machine sends a tick late, it
      // does not move it. Every body's newest pose as it is (its dt_us says how old).
      const std::int64_t t = next_tick;
      states.clear();
      fusion.predict_all(t, t + ips::realtime_minus_monotonic_ns(), *rt->fusion, states);
      body_states.clear();
      if (bodies) bodies->latest(t, body_states);
      publish(states, body_states, t, t + ips::realtime_minus_monotonic_ns(), 0, *rt);
      // The next tick of the grid after now: ticks a stall made this thread miss are skipped.
      next_tick += period * (1 + (woke - next_tick) / period);
    }
    if (bodies) {
      stats_.late += bodies->late() - counted_body_late;
      counted_body_late = bodies->late();
      stats_.held_for_cameras += bodies->held_for_cameras() - counted_body_held;
      counted_body_held = bodies->held_for_cameras();
    }
    stats_.late += fusion.counters().late - counted_late;
    stats_.too_old += fusion.counters().too_old - counted_too_old;
    counted_late = fusion.counters().late;
    counted_too_old = fusion.counters().too_old;
    stats_.held_for_cameras += fusion.counters().held_for_cameras - counted_held;
    counted_held = fusion.counters().held_for_cameras;
    stats_.camera_hold_s = fusion.effective_camera_hold_s();
  }
}

void FusionWorker::publish(const std::vector<ips::FusedMarker>& states, const std::vector<ips::FusedBody>& bodies,
                           std::int64_t t_mono_ns, std::int64_t t_real_ns, std::int64_t t_delivered_ns,
                           const Runtime& rt) {
  ips::Datagram d;
  d.capture_monotonic_ns = t_mono_ns;  // per-frame: the frame's capture time; fixed rate: the prediction time
  d.capture_realtime_ns = t_real_ns;
  d.update = update_++;
  d.has_velocity = rt.config.fusion.kalman;
  // Where another source than the cameras can place a marker, every record says what placed it.
  d.has_sources = rt.config.ranging.enabled() || !rt.config.on_robot.empty();
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
    m.dt_us = dt_us(f.t_mono_ns, d.capture_monotonic_ns);
    m.vx = f.velocity.x();
    m.vy = f.velocity.y();
    m.vz = f.velocity.z();
    m.sources = f.sources;
    m.has_yaw = f.has_yaw;
    m.covariance = {f.covariance(0, 0), f.covariance(0, 1), f.covariance(0, 2),
                    f.covariance(1, 1), f.covariance(1, 2), f.covariance(2, 2)};
    d.markers.push_back(m);
  }
  // Protocol version 2 exactly when bodies are configured: labs without bodies keep sending
  // version 1, which their existing clients read (include/ips/output/wire.h).
  if (!rt.config.bodies.empty()) d.version = IPS_WIRE_VERSION_2;
  for (const ips::FusedBody& f : bodies) {
    ips::BodyRecord b;
    b.name = f.name;
    b.camera_mask = f.camera_mask;
    b.x = f.pose.position.x();
    b.y = f.pose.position.y();
    b.z = f.pose.position.z();
    b.yaw = f.pose.yaw;
    b.qw = f.pose.q.w();
    b.qx = f.pose.q.x();
    b.qy = f.pose.q.y();
    b.qz = f.pose.q.z();
    b.quality = f.quality;
    b.spread = f.spread;
    b.dt_us = dt_us(f.t_mono_ns, d.capture_monotonic_ns);
    b.has_yaw = f.has_yaw;
    b.id_count = static_cast<std::uint16_t>(std::min<std::size_t>(f.marker_ids.size(), 0xffff));
    for (std::size_t k = 0; k < f.marker_ids.size() && k < IPS_WIRE_BODY_MAX_IDS; ++k)
      b.ids.push_back(static_cast<std::uint32_t>(f.marker_ids[k]));
    b.has_velocity = f.has_velocity;
    b.vx = f.velocity.x();
    b.vy = f.velocity.y();
    b.vz = f.velocity.z();
    b.has_yaw_rate = f.has_yaw_rate;
    b.yaw_rate = f.yaw_rate;
    b.sources = f.sources;
    b.covariance = {f.covariance(0, 0), f.covariance(0, 1), f.covariance(0, 2),
                    f.covariance(1, 1), f.covariance(1, 2), f.covariance(2, 2)};
    d.bodies.push_back(std::move(b));
  }
  // Only the range input reads these (robots as mobile anchors): no lock per update without it.
  if (latest_ && rt.config.ranging.enabled()) {
    latest_->update(states);
    latest_->update(bodies);
  }
  rt.publisher->publish(d);
  if (web_) web_->publish(d);                     // a copy into a bounded inbox; never waits for browsers
  const std::int64_t sent = ips::monotonic_ns();  // after the last sendto of the update
  if (t_delivered_ns > 0) stats_.latency.add(sent - t_delivered_ns, sent - t_mono_ns);
  ++stats_.updates;
  stats_.last_latency_ns = rt.publisher->last_latency_ns();
  std::lock_guard lock(stats_.outputs_mutex);
  stats_.outputs = rt.publisher->stats();
}

}  // namespace ipsd
