// outputs[i] with type ros2: ROS 2 messages over DDS (docs/ros2.md). The topic names are built
// from the prefix and the marker names, so both are checked here as ROS 2 names: a name ROS 2
// would refuse must stop the daemon at start (exit 2), not vanish on the robots' side.
#include <cstdlib>
#include <map>
#include <string>

#include "output/parse_output.h"
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
           "'" + o.prefix +
               "' is not a ROS 2 namespace (tokens of letters, digits and _, not starting with a "
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
  if (!o.pose && !o.odometry && !o.tf)
    r.fail(n, r.key("pose"), "pose, odometry and tf are all off: nothing to publish");

  o.reliable = pick<bool>(r, "qos", {{"best_effort", false}, {"reliable", true}}, o.reliable, false);
  r.get("depth", o.depth);
  if (o.depth < 1 || o.depth > 1000) r.fail(n["depth"], r.key("depth"), "must be 1..1000 (keep-last history)");
}

}  // namespace ips::config_detail
