// A simulated lab for the survey tests, unlike the published one: four cameras in a row
// along y at 2.4-3.0 m with tilts up to ~4.5 degrees, three reference markers on the floor
// that camera "d" does not see, and a wand (markers 30 and 31 on one stick, 0.4 m apart at
// 0.10 m and 0.45 m) walked through the cameras' overlaps with 1 s pauses.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace ips::test {

struct LabCamera {
  const char* name;
  const char* intrinsics;  // calib_data/ou2023/<this>
  double x, y, z;
  double roll, pitch, yaw;  // degrees
  double phase_s;           // unsynchronised cameras
};

inline const std::vector<LabCamera>& lab_cameras() {
  static const std::vector<LabCamera> cams = {
      {"a", "intrinsics_red.yaml", 2.50, 1.30, 2.40, 3.0, -2.0, 1.0, 0.000},
      {"b", "intrinsics_white.yaml", 2.40, 3.10, 2.60, -4.0, 1.5, -2.0, 0.011},
      {"c", "intrinsics_black.yaml", 2.60, 4.90, 2.80, 2.0, 4.0, 0.5, 0.022},
      {"d", "intrinsics_red.yaml", 2.50, 6.70, 3.00, -1.0, -3.0, 3.0, 0.033},
  };
  return cams;
}

struct LabReference {
  int id;
  double x, y;
};

inline const std::vector<LabReference>& lab_references() {
  static const std::vector<LabReference> refs = {{20, 1.6, 0.8}, {21, 3.4, 1.4}, {22, 2.0, 3.3}};
  return refs;
}

/// Pause points of the wand (marker 30; marker 31 is 0.4 m further along x): four in each
/// overlap of neighbouring cameras, so each camera is chained to the next.
inline std::vector<std::pair<double, double>> lab_wand_points() {
  return {{1.0, 1.95}, {2.2, 2.35}, {3.2, 1.95}, {4.0, 2.3},    // a/b
          {3.9, 4.15}, {2.8, 3.8},  {1.9, 4.2},  {0.9, 3.85},   // b/c
          {1.0, 5.65}, {2.1, 6.0},  {3.1, 5.6},  {4.0, 5.95}};  // c/d
}

/// The scene YAML; `calib_dir` is the absolute calib_data directory; `pause` the wand's
/// stop at every point, seconds; `speed` m/s; `extra_markers` more marker entries.
inline std::string lab_scene(const std::string& calib_dir, double pause, double speed,
                             const std::string& extra_markers = "") {
  std::string s =
      "dictionary: DICT_4X4_100\n"
      "floor: {size: [5.0, 8.0], grey: 120, texture_contrast: 18, texture_scale: 0.05, seed: 3}\n"
      "render: {supersample: 3, noise_sigma: 2.0, jpeg_quality: 90, vignetting: 0.35, gradient: 0.15, "
      "exposure: 0.0, blur_samples: 5, white: 215, black: 30, seed: 5}\n"
      "cameras:\n";
  char buf[400];
  for (const auto& c : lab_cameras()) {
    std::snprintf(buf, sizeof buf,
                  "  - {name: %s, intrinsics: %s/ou2023/%s, position: [%.3f, %.3f, %.3f], rotation_deg: [%.2f, "
                  "%.2f, %.2f]}\n",
                  c.name, calib_dir.c_str(), c.intrinsics, c.x, c.y, c.z, c.roll, c.pitch, c.yaw);
    s += buf;
  }
  s += "markers:\n";
  for (const auto& r : lab_references()) {
    std::snprintf(buf, sizeof buf, "  - {id: %d, length: 0.20, x: %.3f, y: %.3f, height: 0.0, yaw_deg: %d}\n", r.id,
                  r.x, r.y, 17 * r.id);
    s += buf;
  }
  for (int k = 0; k < 2; ++k) {
    std::string pts;
    for (const auto& [x, y] : lab_wand_points()) {
      std::snprintf(buf, sizeof buf, "%s[%.3f, %.3f]", pts.empty() ? "" : ", ", x + 0.4 * k, y);
      pts += buf;
    }
    std::snprintf(buf, sizeof buf, "  - {id: %d, length: 0.20, height: %.2f, trajectory: {type: waypoints, ", 30 + k,
                  k == 0 ? 0.10 : 0.45);
    s += buf;
    std::snprintf(buf, sizeof buf, "speed: %.3f, pause: %.3f, points: [", speed, pause);
    s += buf + pts + "]}}\n";
  }
  return s + extra_markers;
}

}  // namespace ips::test
