// outputs[i] of the configuration, one parser per output type (src/output/parse_output*.cpp).
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "core/map_reader.h"
#include "ips/output/output_settings.h"

namespace ips::config_detail {

/// outputs[index]: one output of any type.
OutputConfig parse_output(const YAML::Node& n, int index, const std::string& file);
/// The type-specific keys of a mavlink output (parse_output_mavlink.cpp).
void parse_mavlink_output(MapReader& r, const YAML::Node& n, OutputConfig& o, const std::string& file);
/// The type-specific keys of a subscriptions output (parse_output_subscriptions.cpp).
void parse_subscriptions_output(MapReader& r, const YAML::Node& n, OutputConfig& o);
/// `allow`: a non-empty list of IPv4 subnets (the subscriptions output, the range input).
void read_allow_list(MapReader& r, std::vector<std::string>& allow);
/// outputs[i] of type ros2 (parse_output_ros2.cpp).
void parse_ros2_output(MapReader& r, const YAML::Node& n, Ros2OutputSettings& o);

}  // namespace ips::config_detail
