// robot.yaml: the camera a robot carries for inside-out localisation (docs/inside-out.md):
//
//   camera:
//     intrinsics: up_camera.yaml        # relative to this file
//     mount:                            # optional; the default: lens at the robot's origin,
//       offset: [0.10, 0.0, 0.25]       #   looking straight up, image +x forward
//       yaw_deg: 0                      # image +x from the robot's forward axis
//       roll_deg: 0
//       pitch_deg: 0
//   detection: { ... }                  # optional, as ipsd's (the dictionary is the map's)
//   localise:                           # optional
//     pixel_sigma: 0.5                  # corner noise, px (scales the reported sigmas)
//     outlier_px: 3.0                   # a marker off by more (RMS) is left out
//     tilt_sigma_deg: 1.0               # how level the floor is (0: tilt from the markers alone)
//
// Strict: an unknown key, a wrong type or a missing file throws ips::InputError naming the
// file, line and key.
#pragma once

#include <filesystem>
#include <string>

#include "ips/detect/detector.h"
#include "ips/insideout/localise.h"

namespace ips {

struct RobotCameraConfig {
  std::filesystem::path file;        ///< where it was read from
  std::filesystem::path intrinsics;  ///< the up-facing camera's calibration
  CameraMount mount;
  DetectorOptions detection;
  LocaliseOptions localise;
};

RobotCameraConfig load_robot_config(const std::filesystem::path& path);
RobotCameraConfig parse_robot_config(const std::string& yaml_text, const std::filesystem::path& path);

}  // namespace ips
