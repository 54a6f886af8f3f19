// Cross-section check of the configuration: the ros2 outputs' topic names (src/config/attach_ros2_names.cpp).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/config/config.h"

namespace ips::config_detail {

/// Gives every ros2 output the marker names, after every section was read; checks marker and body
/// names as ROS 2 name tokens and that no two share a topic. `root` is the whole document (for the
/// line of a bad name).
void attach_ros2_names(DaemonConfig& c, const YAML::Node& root, const std::string& file);

}  // namespace ips::config_detail
