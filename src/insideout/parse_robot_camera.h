// The robot camera's YAML blocks, read alike in robot.yaml (camera.mount, localise: ips
// localise / ips map) and in ipsd.yaml (cameras[].on_robot: the live daemon).
#pragma once

#include <filesystem>
#include <string>

#include <yaml-cpp/yaml.h>

#include "core/map_reader.h"
#include "ips/insideout/localise.h"
#include "ips/insideout/on_robot.h"

namespace ips::config_detail {

/// offset, yaw_deg, roll_deg, pitch_deg of `r`'s mapping (other keys are left to the caller).
CameraMount read_camera_mount(MapReader& r);
/// pixel_sigma, outlier_px, tilt_sigma_deg of `r`'s mapping, over `options`' values.
void read_localise_options(MapReader& r, LocaliseOptions& options);
/// cameras[i].on_robot (`key` names it in messages); map relative to `base`, must exist.
OnRobotSettings parse_on_robot(const YAML::Node& n, const std::string& key, const std::filesystem::path& base,
                               const std::string& file);

}  // namespace ips::config_detail
