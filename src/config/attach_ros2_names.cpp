// The ros2 outputs' topic names come from the marker and body names of other sections, so they are
// checked here, after every section was read: a name ROS 2 would refuse must stop the daemon at
// start (exit 2), not vanish on the robots' side.
#include <map>
#include <string>

#include <yaml-cpp/yaml.h>

#include "config/attach_ros2_names.h"
#include "ips/core/error.h"
#include "output/ros2_names.h"

namespace ips::config_detail {

void attach_ros2_names(DaemonConfig& c, const YAML::Node& root, const std::string& file) {
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
                         "digit), as outputs[" +
                         std::to_string(i) + "] (ros2) needs");
      }
      if (const auto [it, fresh] = taken.emplace(info.name, id); !fresh)
        throw InputError(file + ": markers.ids." + std::to_string(id) + ".name: '" + info.name +
                         "' is also the name of marker " + std::to_string(it->second) + " (outputs[" +
                         std::to_string(i) + "] (ros2) would publish both on one topic)");
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
                         "digit), as " +
                         needs + " needs");
      if (const auto it = taken.find(name); it != taken.end())
        throw InputError(file + ": " + key + ": '" + name + "' is also the name of marker " +
                         std::to_string(it->second) + " (" + needs + " would publish both on one topic)");
      if (name.rfind("marker_", 0) == 0 && name.size() > 7 &&
          name.find_first_not_of("0123456789", 7) == std::string::npos)
        throw InputError(file + ": " + key + ": '" + name + "' is the ROS 2 name of unnamed marker " + name.substr(7) +
                         " (" + needs + " would publish both on one topic)");
    }
  }
}

}  // namespace ips::config_detail
