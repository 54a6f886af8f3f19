// markers: of the configuration (src/geometry/parse_markers.cpp).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/geometry/marker_settings.h"

namespace ips::config_detail {

MarkerConfig parse_markers(const YAML::Node& n, const std::string& file);

}  // namespace ips::config_detail
