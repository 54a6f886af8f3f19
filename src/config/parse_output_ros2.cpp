// outputs[i] with type ros2: ROS 2 messages over DDS (README "ROS 2"). The topic names are built
// from the prefix and the marker names, so both are checked here as ROS 2 names: a name ROS 2
// would refuse must stop the daemon at start (exit 2), not vanish on the robots' side.
#include <cstdlib>
#include <map>
#include <string>

#include "map_reader.h"
#include "output/ros2_names.h"

namespace ips::config_detail {

namespace {
constexpr int kMaxDomain = 232;  // the largest id Cyclone DDS / ROS 2 map to UDP ports
}  // namespace

void parse_ros2_output(MapReader& r, const YAML::Node& n, Ros2OutputSettings& o) {
  if (r.has("domain")) {
    r.get("domain", o.domain);
    if (o.domain < 0 || o.domain > kMaxDomain)
      r.fail(n["domain"], r.key("domain"), "must be 0.." + std::to_string(kMaxDomain) + " (the ROS_DOMAIN_ID)");
  } else if (const char* env = std::getenv("ROS_DOMAIN_ID"); env && *env) {
    // ROS 2 semantics: the environment chooses the domain when the configuration does not.
    char* end = nullptr;
    const long d = std::strtol(env, &end, 10);
    if (*end != '\0' || d < 0 || d > kMaxDomain)
      r.fail(n, r.key("domain"),
             std::string("not set, and ROS_DOMAIN_ID='") + env + "' is not 0.." + std::to_string(kMaxDomain));
    o.domain = static_cast<int>(d);
  }

  r.get("prefix", o.prefix);
  if (!o.prefix.empty() && o.prefix.front() == '/') o.prefix.erase(0, 1);  // "/ipsd" = "ipsd"
  if (o.prefix.empty()) r.fail(n["prefix"], r.key("prefix"), "empty (the topics are /<prefix>/<name>/pose)");
  if (!ros2::is_namespace(o.prefix))
    r.fail(n["prefix"], r.key("prefix"),
           "'" + o.prefix + "' is not a ROS 2 namespace (tokens of letters, digits and _, not starting with a "
           "digit, separated by single '/')");

  for (const char* k : {"frame_id", "child_frame_id"}) {
    std::string& v = std::string(k) == "frame_id" ? o.frame_id : o.child_frame_id;
    r.get(k, v);
    if (v.empty()) r.fail(n[k], r.key(k), "empty frame name");
    if (v.front() == '/') r.fail(n[k], r.key(k), "a tf2 frame name must not start with '/'");
  }

  r.get("pose", o.pose);
  r.get("odometry", o.odometry);
  r.get("tf", o.tf);
  if (!o.pose && !o.odometry && !o.tf) r.fail(n, r.key("pose"), "pose, odometry and tf are all off: nothing to publish");

  o.reliable = pick<bool>(r, "qos", {{"best_effort", false}, {"reliable", true}}, o.reliable, false);
  r.get("depth", o.depth);
  if (o.depth < 1 || o.depth > 1000) r.fail(n["depth"], r.key("depth"), "must be 1..1000 (keep-last history)");
}

void attach_ros2_marker_names(DaemonConfig& c, const YAML::Node& root, const std::string& file) {
  for (std::size_t i = 0; i < c.outputs.size(); ++i) {
    OutputConfig& o = c.outputs[i];
    if (o.kind != OutputConfig::Kind::kRos2) continue;
    std::map<std::string, int> taken;  // name -> marker id: two markers on one topic is an error
    for (const auto& [id, info] : c.markers.ids) {
      if (info.name.empty()) continue;
      if (!ros2::is_name_token(info.name)) {
        std::string at = file;
        // The node is found again for its line; an id written unusually ("07") just has none.
        const YAML::Node markers = root["markers"];
        const YAML::Node ids = markers ? markers["ids"] : YAML::Node();
        const YAML::Node entry = ids ? ids[std::to_string(id)] : YAML::Node();
        if (entry && entry.IsMap() && entry["name"]) {
          const YAML::Mark m = entry["name"].Mark();
          // Appended piecewise: GCC 12 warns -Wrestrict on "literal" + std::string.
          at += ':';
          at += std::to_string(m.line + 1);
          at += ':';
          at += std::to_string(m.column + 1);
        }
        throw InputError(at + ": markers.ids." + std::to_string(id) + ".name: '" + info.name +
                         "' is not usable in a ROS 2 topic name (letters, digits and _, not starting with a "
                         "digit), as outputs[" + std::to_string(i) + "] (ros2) needs");
      }
      if (const auto [it, fresh] = taken.emplace(info.name, id); !fresh)
        throw InputError(file + ": markers.ids." + std::to_string(id) + ".name: '" + info.name +
                         "' is also the name of marker " + std::to_string(it->second) +
                         " (outputs[" + std::to_string(i) + "] (ros2) would publish both on one topic)");
      o.ros2.marker_names[id] = info.name;
    }
    // Bodies publish under their names beside the markers (/<prefix>/<body name>/pose, the
    // Ros2Sink): the same rules, one namespace.
    for (std::size_t b = 0; b < c.bodies.size(); ++b) {
      const std::string& name = c.bodies[b].name;
      const std::string key = "bodies[" + std::to_string(b) + "].name";
      const std::string needs = "outputs[" + std::to_string(i) + "] (ros2)";
      if (!ros2::is_name_token(name))
        throw InputError(file + ": " + key + ": '" + name +
                         "' is not usable in a ROS 2 topic name (letters, digits and _, not starting with a "
                         "digit), as " + needs + " needs");
      if (const auto it = taken.find(name); it != taken.end())
        throw InputError(file + ": " + key + ": '" + name + "' is also the name of marker " +
                         std::to_string(it->second) + " (" + needs + " would publish both on one topic)");
      if (name.rfind("marker_", 0) == 0 && name.size() > 7 &&
          name.find_first_not_of("0123456789", 7) == std::string::npos)
        throw InputError(file + ": " + key + ": '" + name + "' is the ROS 2 name of unnamed marker " +
                         name.substr(7) + " (" + needs + " would publish both on one topic)");
    }
  }
}

}  // namespace ips::config_detail
