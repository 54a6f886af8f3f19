// What the daemon tells its web view (ips/web.h): the map's layout from the running
// configuration and model, and the status document with the web view's own counters.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "ips/web.h"
#include "pipeline.h"

namespace ipsd {

/// /layout.json: floor outline, each camera's footprint and position (from its pose model,
/// where it has one), its configured controls, the markers' names.
std::string web_layout(const Runtime& runtime);

/// The web view's counters as a JSON object (the "web" field of the status document).
nlohmann::json web_counters_json(const ips::WebCounters& c);

}  // namespace ipsd
