// outputs[i] of type mavlink: MAVLink 2 pose messages per vehicle (docs/mavlink.md).
#include <set>

#include "output/parse_output.h"

namespace ips::config_detail {

namespace {

MavlinkVehicle parse_vehicle(const YAML::Node& n, const std::string& key, const std::string& file) {
  MapReader r(n, key, file);
  MavlinkVehicle v;
  r.get("marker", v.marker, true);
  if (v.marker < 0) r.fail(n["marker"], r.key("marker"), "must be a marker id >= 0");
  r.get("system_id", v.system_id, true);
  // 0 is the broadcast address and cannot identify a sender; ids are 8-bit.
  if (v.system_id < 1 || v.system_id > 255) r.fail(n["system_id"], r.key("system_id"), "must be 1..255");
  r.get("address", v.address);
  int port = 0;
  r.get("port", port);
  if (r.has("port") && (port < 1 || port > 65535)) r.fail(n["port"], r.key("port"), "must be 1..65535");
  v.port = static_cast<std::uint16_t>(port);
  r.get("marker_yaw_deg", v.marker_yaw_deg);
  r.finish();
  return v;
}

}  // namespace

void parse_mavlink_output(MapReader& r, const YAML::Node& n, OutputConfig& o, const std::string& file) {
  MavlinkOutputSettings& m = o.mavlink;
  r.get("address", o.address, true);
  int port = 0;
  r.get("port", port, true);
  if (port < 1 || port > 65535) r.fail(n["port"], r.key("port"), "must be 1..65535");
  o.port = static_cast<std::uint16_t>(port);

  if (!r.has("vehicles")) r.fail(n, r.key("vehicles"), "required key is missing");
  const YAML::Node vehicles = r.node("vehicles");
  if (!vehicles.IsSequence() || vehicles.size() == 0)
    r.fail(vehicles, r.key("vehicles"), "expected a non-empty list of {marker, system_id}");
  std::set<int> markers, systems;
  for (std::size_t i = 0; i < vehicles.size(); ++i) {
    const std::string key = r.key("vehicles[" + std::to_string(i) + "]");
    m.vehicles.push_back(parse_vehicle(vehicles[i], key, file));
    if (!markers.insert(m.vehicles.back().marker).second)
      r.fail(vehicles[i]["marker"], key + ".marker",
             "marker " + std::to_string(m.vehicles.back().marker) + " is already a vehicle");
    if (!systems.insert(m.vehicles.back().system_id).second)
      r.fail(vehicles[i]["system_id"], key + ".system_id",
             "system id " + std::to_string(m.vehicles.back().system_id) + " is already a vehicle");
  }

  if (r.has("messages")) {
    const YAML::Node messages = r.node("messages");
    if (!messages.IsSequence() || messages.size() == 0)
      r.fail(messages, r.key("messages"), "expected a non-empty list (vision_position_estimate, odometry)");
    m.vision_position_estimate = m.odometry = false;
    for (const auto& item : messages) {
      const std::string name = item.IsScalar() ? item.Scalar() : "";
      if (name == "vision_position_estimate")
        m.vision_position_estimate = true;
      else if (name == "odometry")
        m.odometry = true;
      else
        r.fail(item, r.key("messages"), "unknown message '" + name + "' (vision_position_estimate|odometry)");
    }
  }
  r.get("component_id", m.component_id);
  if (m.component_id < 1 || m.component_id > 255) r.fail(n["component_id"], r.key("component_id"), "must be 1..255");
  r.get_number("rate_limit", m.rate_limit_hz, 0.0, true);
  r.get("yaw_offset_deg", m.yaw_offset_deg);
  if (r.has("track_gap")) {
    double gap = 0;
    r.get_number("track_gap", gap, 0.0, true);
    m.track_gap_s = gap;
  }
  r.get_number("yaw_stddev_deg", m.yaw_stddev_deg, 0.0, true);
  r.get("heartbeat", m.heartbeat);
}

}  // namespace ips::config_detail
