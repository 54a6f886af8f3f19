// What the daemon tells its web view (ips/web/web.h): the map's layout from the running
// configuration and model, and the status document with the web view's own counters.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ips/body/body.h"
#include "ips/web/web.h"
#include "pipeline.h"

namespace ipsd {

/// /layout.json: floor outline, each camera's footprint and position (from its pose model,
/// where it has one), its configured controls, the markers' names, the bodies' shapes.
std::string web_layout(const Runtime& runtime);

/// The bodies of /layout.json: per body its name, whether it is a ground robot, and per marker
/// its id, edge, plate and the plate's outline seen from above in the body frame (x, y).
nlohmann::json body_layout(const std::vector<ips::BodyDef>& bodies);

/// The web view's counters as a JSON object (the "web" field of the status document).
nlohmann::json web_counters_json(const ips::WebCounters& c);

}  // namespace ipsd
