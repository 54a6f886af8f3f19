// ROS 2 naming for the ros2 output, free of DDS: which names are valid, what a marker and its
// frame are called, and the DDS topic a ROS topic maps to (ROS 2 design article "Topic and
// Service name mapping to DDS": ROS topics live under the `rt/` prefix).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "ips/output/output_settings.h"

namespace ips::ros2 {

/// One token of a ROS 2 name: [A-Za-z_][A-Za-z0-9_]* (no '/', not starting with a digit).
bool is_name_token(std::string_view s);
/// A relative ROS 2 namespace: tokens joined by single '/', no leading or trailing '/'.
bool is_namespace(std::string_view s);

/// markers.ids.<id>.name, or "marker_<id>" for an unnamed marker.
std::string marker_name(const Ros2OutputSettings& s, std::uint32_t id);
/// child_frame_id with "{name}" and "{id}" replaced for marker `id`.
std::string child_frame(const Ros2OutputSettings& s, std::uint32_t id);
/// "rt/<prefix>/<marker name>/<leaf>" (the ROS topic /<prefix>/<marker name>/<leaf>).
std::string marker_topic(const Ros2OutputSettings& s, std::uint32_t id, std::string_view leaf);
/// A body's: "rt/<prefix>/<body name>/<leaf>", and child_frame_id with both "{name}" and
/// "{id}" replaced by the body's name (a body has no single marker id).
std::string body_topic(const Ros2OutputSettings& s, const std::string& body, std::string_view leaf);
std::string body_child_frame(const Ros2OutputSettings& s, const std::string& body);
/// The DDS name of the ROS topic /tf.
inline constexpr const char* kTfTopic = "rt/tf";

/// ROS 2 time of a CLOCK_REALTIME instant (builtin_interfaces/Time: sec, nanosec in 0..1e9).
struct Stamp {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
};
Stamp to_stamp(std::int64_t realtime_ns);

/// Rotation by `yaw` about +z as a unit quaternion (x, y, z, w).
struct Quaternion {
  double x = 0, y = 0, z = 0, w = 1;
};
Quaternion yaw_quaternion(double yaw);

}  // namespace ips::ros2
