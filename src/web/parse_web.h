// web: of the configuration (src/web/parse_web.cpp).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/web/web_settings.h"

namespace ips::config_detail {

/// web: {listen: "127.0.0.1:8080", ...}. The address is checked here so that a typo stops
/// the start (exit 2) with the key's place rather than failing in the server.
void parse_web(const YAML::Node& node, const std::string& file, WebConfig& w);

}  // namespace ips::config_detail
