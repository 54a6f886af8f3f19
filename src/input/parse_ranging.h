// ranging: of the configuration (src/input/parse_ranging.cpp).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/input/ranging_settings.h"

namespace ips::config_detail {

/// ranging: {port, address, allow, psk, rate_per_source, reorder_window, max_clock_ahead,
/// method, height | z_range, sigma, anchors: [{id, x, y, z, bias, scale, sigma}],
/// tags: [{id, marker}]}. Throws InputError with file:line and the key.
RangingConfig parse_ranging(const YAML::Node& node, const std::string& file);

}  // namespace ips::config_detail
