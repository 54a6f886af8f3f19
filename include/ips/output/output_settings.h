// outputs[i] of the lab's configuration: where and how the fused positions are sent. Parsed by
// src/output/parse_output*.cpp; docs/configuration.md lists every key.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ips/output/packet_codec.h"

namespace ips {

/// One vehicle of a MAVLink output (outputs[i].vehicles[j]): the marker it carries.
struct MavlinkVehicle {
  int marker = -1;            ///< required: ArUco id of the marker on the vehicle
  int system_id = 0;          ///< required: the vehicle's MAVLink system id, 1..255
  std::string address;        ///< destination host; "" = the output's address
  std::uint16_t port = 0;     ///< destination port; 0 = the output's port
  double marker_yaw_deg = 0;  ///< heading of the marker's x axis relative to the vehicle's nose, degrees (CCW)

  bool operator==(const MavlinkVehicle&) const = default;
};

/// type: mavlink (src/output/mavlink_sink.cpp; docs/mavlink.md).
struct MavlinkOutputSettings {
  std::vector<MavlinkVehicle> vehicles;  ///< required, non-empty
  bool vision_position_estimate = true;  ///< messages: send VISION_POSITION_ESTIMATE (message 102)
  bool odometry = false;                 ///< messages: send ODOMETRY (message 331)
  int component_id = 197;                ///< MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
  double rate_limit_hz = 30.0;           ///< at most this many pose messages per vehicle per second
  double yaw_offset_deg = 0.0;           ///< heading of the lab's x axis in the autopilot's frame (clockwise)
  double track_gap_s = std::nan("");     ///< unseen longer than this = new track; NaN = fusion.kalman.reset_after
  double yaw_stddev_deg = 5.0;           ///< attitude standard deviation reported in the covariance
  bool heartbeat = true;                 ///< HEARTBEAT (message 0) at 1 Hz per vehicle

  bool operator==(const MavlinkOutputSettings&) const = default;
};

/// type: subscriptions (src/output/subscription_sink.cpp; protocol in include/ips/output/wire.h).
struct SubscriptionSettings {
  std::vector<std::string> allow = {"0.0.0.0/0"};  ///< IPv4 subnets (CIDR) that may subscribe
  std::string psk;                                 ///< pre-shared key for HMAC-SHA256 over requests; "" = none
  int max_subscribers = 16;                        ///< verified subscribers at once
  double max_lease_s = 60.0;                       ///< a longer requested lease is shortened to this

  bool operator==(const SubscriptionSettings&) const = default;
};

/// outputs[i] of type ros2: ROS 2 messages over DDS (docs/ros2.md; src/output/ros2_sink.h).
struct Ros2OutputSettings {
  int domain = 0;                  ///< DDS domain 0..232; key absent: $ROS_DOMAIN_ID if set, else 0
  std::string prefix = "ipsd";     ///< ROS namespace of the topics: /<prefix>/<name>/pose
  std::string frame_id = "world";  ///< header.frame_id of poses and odometry, the TF parent frame
  /// Odometry child_frame_id and TF child frame; "{name}" and "{id}" are replaced per marker.
  std::string child_frame_id = "{name}";
  bool pose = true;       ///< geometry_msgs/PoseStamped on <prefix>/<name>/pose
  bool odometry = true;   ///< nav_msgs/Odometry on <prefix>/<name>/odom (updates with velocity only)
  bool tf = false;        ///< tf2_msgs/TFMessage on /tf (always reliable: tf2 listeners ask for it)
  bool reliable = false;  ///< qos: best_effort (false) | reliable
  int depth = 5;          ///< keep-last history depth per topic, 1..1000
  /// Not a key: markers.ids.<id>.name of every named marker, copied at load time (the ROS name
  /// of an unnamed marker is marker_<id>).
  std::map<int, std::string> marker_names;

  bool operator==(const Ros2OutputSettings&) const = default;
};

struct OutputConfig {
  enum class Kind { kUnicast, kBroadcast, kMulticast, kMavlink, kSubscriptions, kRos2 };
  Kind kind = Kind::kUnicast;  ///< required: unicast | broadcast | multicast | mavlink | subscriptions | ros2
  std::string address;         ///< required: IPv4 host / broadcast address / multicast group
  std::uint16_t port = 0;      ///< required: UDP port
  WireFormat format = WireFormat::kBinary;  ///< binary | json
  int ttl = 1;                              ///< multicast TTL (1 = this subnet only)
  std::string interface;                    ///< multicast: IPv4 address of the sending interface; "" = default route
  MavlinkOutputSettings mavlink;            ///< type mavlink (address/port: the default destination)
  SubscriptionSettings subscriptions;       ///< type subscriptions (address/port: where to listen)
  Ros2OutputSettings ros2;                  ///< type ros2 only
  std::string describe() const;             ///< "multicast 239.1.2.3:5005 (json)"

  bool operator==(const OutputConfig&) const = default;
};

}  // namespace ips
