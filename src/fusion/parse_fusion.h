// fusion: of the configuration (src/fusion/parse_fusion.cpp).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/fusion/fusion_settings.h"

namespace ips::config_detail {

FusionConfig parse_fusion(const YAML::Node& n, const std::string& file);

}  // namespace ips::config_detail
