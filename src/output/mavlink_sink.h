// type: mavlink — MAVLink 2 pose messages for PX4 / ArduPilot vehicles over UDP (docs/mavlink.md).
// Per configured vehicle: the marker's pose converted from the lab frame (x forward, y left,
// z up) to the autopilot's local NED/FRD frame, sent as VISION_POSITION_ESTIMATE and/or
// ODOMETRY under the vehicle's system id, at most rate_limit_hz, with reset_counter counting
// track restarts; a HEARTBEAT per vehicle each second while the stream runs.
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <string>
#include <vector>

#include "ips/output/mavlink_frame.h"
#include "ips/output/mavlink_pose.h"
#include "ips/output/output_sink.h"

namespace ips {

class MavlinkSink final : public OutputSink {
 public:
  MavlinkSink(const OutputConfig& config, const std::string& where);
  ~MavlinkSink() override;
  MavlinkSink(const MavlinkSink&) = delete;
  MavlinkSink& operator=(const MavlinkSink&) = delete;

  void publish(const Datagram& update) override;
  OutputStats stats() const override { return stats_; }
  std::int64_t last_latency_ns() const override { return last_latency_ns_; }

 private:
  struct Vehicle {
    MavlinkVehicle config;
    sockaddr_in to{};
    std::uint8_t sequence = 0;  ///< MAVLink packet sequence of this (system, component)
    double tokens = 1.0;        ///< rate limit: token bucket, capacity 2
    std::int64_t last_token_ns = 0;
    std::int64_t last_seen_ns = -1;  ///< marker time of the last sighting (monotonic)
    std::uint8_t reset_counter = 0;
    std::int64_t last_heartbeat_ns = 0;
    bool heartbeat_sent = false;
    /// The body its marker was last seen on: records of that body placed by ranges alone name
    /// no marker.
    std::string body;
  };
  /// `has_velocity`: m.vx/vy/vz are measured; `yaw_rate`: rad/s counter-clockwise in the lab
  /// (NaN: not measured).
  void send_pose(Vehicle& v, const Datagram& update, const MarkerRecord& m, bool has_velocity, double yaw_rate);
  void send(Vehicle& v, const std::vector<std::uint8_t>& frame, std::int64_t capture_realtime_ns);

  MavlinkOutputSettings settings_;
  std::vector<Vehicle> vehicles_;
  int fd_ = -1;
  OutputStats stats_;
  std::int64_t last_latency_ns_ = 0;
  std::int64_t last_error_log_ns_;
  std::uint64_t errors_since_log_ = 0;
};

}  // namespace ips
