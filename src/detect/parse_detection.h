// detection: of the configuration (src/detect/parse_detection.cpp).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/detect/detector.h"
#include "ips/detect/tracker.h"

namespace ips::config_detail {

/// The detector's tuning (the dictionary comes from markers.dictionary), and the tracking keys
/// (tracking, full_search_period, roi_margin) into `tracking`.
DetectorOptions parse_detection(const YAML::Node& n, const std::string& file, TrackerOptions& tracking);

}  // namespace ips::config_detail
