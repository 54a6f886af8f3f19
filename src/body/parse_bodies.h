// bodies: the configuration's rigid bodies (src/body/parse_bodies.cpp).
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ips/body/body.h"
#include "ips/geometry/marker_settings.h"

namespace ips::config_detail {

/// The list of rigid bodies, checked against the markers section.
std::vector<BodyDef> parse_bodies(const YAML::Node& n, const MarkerConfig& markers, const std::string& file);

}  // namespace ips::config_detail
