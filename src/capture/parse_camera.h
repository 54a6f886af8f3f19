// cameras[i] of the configuration (src/capture/parse_camera.cpp).
#pragma once

#include <filesystem>
#include <string>

#include <yaml-cpp/yaml.h>

#include "ips/capture/camera_settings.h"

namespace ips::config_detail {

/// One camera; relative paths are resolved against `base`. `intrinsics_must_exist` = false when a
/// lab's config is read before its cameras are calibrated (`ips calibrate --config`).
CameraConfig parse_camera(const YAML::Node& n, int index, const std::filesystem::path& base, const std::string& file,
                          bool intrinsics_must_exist);

}  // namespace ips::config_detail
