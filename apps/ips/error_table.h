// Shared output of `ips eval`, `ips cv` and `ips compare`: error tables in cm (human) and
// the JSON shape {"cameras": {"<name>": {"n", "err3d", "err2d"}}} in metres.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "ips/mapping/calib_data.h"
#include "ips/mapping/error_stats.h"

namespace ips::cli {

using ErrorRows = std::vector<std::pair<std::string, CameraErrors>>;

/// Prints a table: one row per entry (label, n, 3-D and 2-D mean/min/max/std in cm).
void print_error_table(const std::string& label_header, const ErrorRows& rows);

/// {"cameras": {label: errors_to_json(...)}} dumped on one line.
void print_error_json(const ErrorRows& rows);

/// The pairs of `camera` in `data`, or ips::InputError naming the file and the cameras it has.
const CalibSet& require_camera(const CalibData& data, const std::string& camera);

}  // namespace ips::cli
