#include "mavlink_sink.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/fusion/kalman.h"
#include "ips/output/wire.h"

namespace ips {

namespace {

constexpr std::int64_t kHeartbeatIntervalNs = 1'000'000'000;
constexpr double kTokenCapacity = 2.0;  // absorbs frame-time jitter at a stream rate == the limit
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

sockaddr_in resolve(const std::string& host, std::uint16_t port, const std::string& key) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  if (::inet_pton(AF_INET, host.c_str(), &to.sin_addr) == 1) return to;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), nullptr, &hints, &res);
  if (rc != 0 || !res) throw InputError(key + ": cannot resolve '" + host + "': " + ::gai_strerror(rc));
  to.sin_addr = reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr;
  ::freeaddrinfo(res);
  return to;
}

/// Upper triangle (row-major, 21 entries) of the 6x6 pose covariance: position block from the
/// fusion, roll/pitch variances `att_var`, yaw variance `yaw_var`. All-zero position covariance
/// = the fusion gave none: NaN in the first element, MAVLink's "unknown".
std::array<float, 21> pose_covariance(const MavlinkPose& p, double att_var, double yaw_var) {
  std::array<float, 21> c{};
  c[0] = static_cast<float>(p.cov[0][0]);
  c[1] = static_cast<float>(p.cov[0][1]);
  c[2] = static_cast<float>(p.cov[0][2]);
  c[6] = static_cast<float>(p.cov[1][1]);
  c[7] = static_cast<float>(p.cov[1][2]);
  c[11] = static_cast<float>(p.cov[2][2]);
  c[15] = c[18] = static_cast<float>(att_var);
  c[20] = static_cast<float>(yaw_var);
  if (p.cov[0][0] == 0 && p.cov[1][1] == 0 && p.cov[2][2] == 0) c[0] = kNaN;
  return c;
}

}  // namespace

MavlinkSink::MavlinkSink(const OutputConfig& c, const std::string& where)
    : settings_(c.mavlink), last_error_log_ns_(-kSendErrorLogIntervalNs) {
  stats_.description = c.describe();
  // Loading fills track_gap from fusion.kalman.reset_after; a config built in code may not.
  if (std::isnan(settings_.track_gap_s)) settings_.track_gap_s = KalmanOptions{}.reset_after_s;
  for (std::size_t i = 0; i < c.mavlink.vehicles.size(); ++i) {
    const MavlinkVehicle& vc = c.mavlink.vehicles[i];
    Vehicle v;
    v.config = vc;
    v.to = resolve(vc.address.empty() ? c.address : vc.address, vc.port ? vc.port : c.port,
                   vc.address.empty() ? where + ".address" : where + ".vehicles[" + std::to_string(i) + "].address");
    vehicles_.push_back(v);
  }
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(where + ": socket: " + std::strerror(errno));
}

MavlinkSink::~MavlinkSink() {
  if (fd_ >= 0) ::close(fd_);
}

void MavlinkSink::publish(const Datagram& update) {
  const std::int64_t now = monotonic_ns();
  for (Vehicle& v : vehicles_) {
    if (settings_.heartbeat && (!v.heartbeat_sent || now - v.last_heartbeat_ns >= kHeartbeatIntervalNs)) {
      send(v,
           mavlink::frame(mavlink::Heartbeat{}, v.sequence++, static_cast<std::uint8_t>(v.config.system_id),
                          static_cast<std::uint8_t>(settings_.component_id)),
           0);
      v.last_heartbeat_ns = now;
      v.heartbeat_sent = true;
    }
    bool sent = false;
    for (const MarkerRecord& m : update.markers)
      if (static_cast<int>(m.id) == v.config.marker) {
        send_pose(v, update, m, update.has_velocity, kNaN);
        sent = true;
        break;
      }
    // A marker on a rigid body is published as the body (version 2): the vehicle then gets the
    // body's pose (origin, heading) from every update its marker contributed to with a known
    // yaw, and from the updates where ranges alone placed the body (heading held, said by the
    // covariance as for a marker; those records name no marker, the vehicle's body does).
    for (const BodyRecord& b : update.bodies) {
      if (sent) break;
      const bool held = !b.has_yaw && (b.sources & IPS_WIRE_SOURCE_RANGES) != 0;
      const bool ours =
          std::find(b.ids.begin(), b.ids.end(), static_cast<std::uint32_t>(v.config.marker)) != b.ids.end() ||
          (held && v.body == b.name);
      if (!ours || (!b.has_yaw && !held)) continue;
      v.body = b.name;
      MarkerRecord m;
      m.id = static_cast<std::uint32_t>(v.config.marker);
      m.camera_mask = b.camera_mask;
      m.x = b.x, m.y = b.y, m.z = b.z, m.yaw = b.yaw;
      m.quality = b.quality;
      m.spread = b.spread;
      m.dt_us = b.dt_us;
      m.vx = b.vx, m.vy = b.vy, m.vz = b.vz;
      m.sources = b.sources;
      m.has_yaw = b.has_yaw;
      m.covariance = b.covariance;
      send_pose(v, update, m, b.has_velocity, b.has_yaw_rate ? b.yaw_rate : kNaN);
      sent = true;
    }
  }
}

void MavlinkSink::send_pose(Vehicle& v, const Datagram& update, const MarkerRecord& m, bool has_velocity,
                            double yaw_rate) {
  const std::int64_t t = update.capture_monotonic_ns + std::int64_t{m.dt_us} * 1000;
  // A sighting after a gap longer than track_gap_s starts a new track: the autopilot must not
  // treat the jump from the old position as motion (reset_counter tells it so).
  if (v.last_seen_ns >= 0 && static_cast<double>(t - v.last_seen_ns) > settings_.track_gap_s * 1e9) ++v.reset_counter;
  // Rate limit on the marker's own time (not the wall clock): deterministic for a given stream.
  if (v.last_seen_ns < 0) {
    v.tokens = 1.0;
  } else if (t > v.last_token_ns) {
    v.tokens =
        std::min(kTokenCapacity, v.tokens + static_cast<double>(t - v.last_token_ns) * 1e-9 * settings_.rate_limit_hz);
  }
  v.last_token_ns = std::max(v.last_token_ns, t);
  v.last_seen_ns = t;
  if (v.tokens < 1.0) return;
  v.tokens -= 1.0;

  const double deg = std::numbers::pi / 180.0;
  const MavlinkPose p = lab_to_ned(m, settings_.yaw_offset_deg * deg, v.config.marker_yaw_deg * deg);
  const double att_var = std::pow(settings_.yaw_stddev_deg * deg, 2);
  // A heading held from the cameras' last sight (a record of ranges alone) is not a measurement:
  // its variance says "anywhere within half a turn", so the autopilot does not steer by it.
  const double yaw_var = m.has_yaw ? att_var : kHeldYawVariance;
  const std::int64_t t_real_ns = update.capture_realtime_ns + std::int64_t{m.dt_us} * 1000;
  const std::uint64_t usec = t_real_ns > 0 ? static_cast<std::uint64_t>(t_real_ns / 1000) : 0;
  const auto sys = static_cast<std::uint8_t>(v.config.system_id);
  const auto comp = static_cast<std::uint8_t>(settings_.component_id);
  if (settings_.vision_position_estimate) {
    mavlink::VisionPositionEstimate e;
    e.usec = usec;
    e.x = static_cast<float>(p.n);
    e.y = static_cast<float>(p.e);
    e.z = static_cast<float>(p.d);
    e.yaw = static_cast<float>(p.heading);  // roll, pitch 0: not observed (a flat marker)
    e.covariance = pose_covariance(p, att_var, yaw_var);
    e.reset_counter = v.reset_counter;
    send(v, mavlink::frame(e, v.sequence++, sys, comp), update.capture_realtime_ns);
  }
  if (settings_.odometry) {
    mavlink::Odometry o;
    o.time_usec = usec;
    o.x = static_cast<float>(p.n);
    o.y = static_cast<float>(p.e);
    o.z = static_cast<float>(p.d);
    o.q = {static_cast<float>(std::cos(p.heading / 2)), 0.0f, 0.0f, static_cast<float>(std::sin(p.heading / 2))};
    if (has_velocity) {
      // child_frame_id BODY_FRD: the velocity rotated by the heading (roll/pitch not observed).
      const double ch = std::cos(p.heading), sh = std::sin(p.heading);
      o.vx = static_cast<float>(ch * p.vn + sh * p.ve);
      o.vy = static_cast<float>(-sh * p.vn + ch * p.ve);
      o.vz = static_cast<float>(p.vd);
    } else {
      o.vx = o.vy = o.vz = kNaN;
    }
    o.rollspeed = o.pitchspeed = kNaN;
    // The heading is clockwise, the lab's yaw counter-clockwise: FRD's yaw speed is -yaw_rate
    // (a level vehicle; roll and pitch rates are not observed).
    o.yawspeed = std::isnan(yaw_rate) ? kNaN : static_cast<float>(-yaw_rate);
    o.pose_covariance = pose_covariance(p, att_var, yaw_var);
    o.velocity_covariance[0] = kNaN;  // the record carries no velocity covariance
    o.reset_counter = v.reset_counter;
    send(v, mavlink::frame(o, v.sequence++, sys, comp), update.capture_realtime_ns);
  }
}

void MavlinkSink::send(Vehicle& v, const std::vector<std::uint8_t>& frame, std::int64_t capture_realtime_ns) {
  const ssize_t n =
      ::sendto(fd_, frame.data(), frame.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&v.to), sizeof v.to);
  if (n == static_cast<ssize_t>(frame.size())) {
    ++stats_.datagrams;
    stats_.bytes += frame.size();
    if (capture_realtime_ns > 0) last_latency_ns_ = realtime_ns() - capture_realtime_ns;
    return;
  }
  const int err = errno;
  ++stats_.send_errors;
  ++errors_since_log_;
  const std::int64_t now = monotonic_ns();
  if (now - last_error_log_ns_ >= kSendErrorLogIntervalNs) {
    spdlog::warn("output {}: send to system {} failed: {} ({} frame(s) lost since the last report)", stats_.description,
                 v.config.system_id, n < 0 ? std::strerror(err) : "short write", errors_since_log_);
    last_error_log_ns_ = now;
    errors_since_log_ = 0;
  }
}

}  // namespace ips
