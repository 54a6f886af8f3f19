#include "insideout/parse_robot_camera.h"

#include <cmath>

namespace ips::config_detail {
namespace robot_camera_keys {

constexpr double kDegree = M_PI / 180.0;

}  // namespace robot_camera_keys

CameraMount read_camera_mount(MapReader& r) {
  using robot_camera_keys::kDegree;
  CameraMount m;
  if (r.has("offset")) {
    const YAML::Node o = r.node("offset");
    if (!o.IsSequence() || o.size() != 3) r.fail(o, r.key("offset"), "expected [x, y, z] in metres");
    for (int i = 0; i < 3; ++i) {
      try {
        m.offset[i] = o[i].as<double>();
      } catch (const YAML::Exception&) {
        r.fail(o[i], r.key("offset"), "expected numbers");
      }
      if (!std::isfinite(m.offset[i])) r.fail(o[i], r.key("offset"), "not a finite number");
    }
  }
  double yaw = 0, roll = 0, pitch = 0;
  r.get("yaw_deg", yaw);
  r.get("roll_deg", roll);
  r.get("pitch_deg", pitch);
  if (!std::isfinite(yaw)) r.fail(r.raw()["yaw_deg"], r.key("yaw_deg"), "not a finite number");
  if (!(std::abs(roll) <= 60) || !(std::abs(pitch) <= 60))
    r.fail(r.raw(), r.key("roll_deg/pitch_deg"), "must be within +-60 (the camera looks up)");
  m.yaw = yaw * kDegree;
  m.roll = roll * kDegree;
  m.pitch = pitch * kDegree;
  return m;
}

void read_localise_options(MapReader& r, LocaliseOptions& options) {
  using robot_camera_keys::kDegree;
  r.get_number("pixel_sigma", options.pixel_sigma, 0, true);
  r.get_number("outlier_px", options.outlier_px, 0, true);
  double tilt_deg = options.tilt_sigma / kDegree;
  r.get_number("tilt_sigma_deg", tilt_deg, 0, false);
  options.tilt_sigma = tilt_deg * kDegree;
}

OnRobotSettings parse_on_robot(const YAML::Node& n, const std::string& key, const std::filesystem::path& base,
                               const std::string& file) {
  MapReader r(n, key, file);
  OnRobotSettings s;
  r.get("marker", s.marker, true);
  if (s.marker < 0) r.fail(n["marker"], r.key("marker"), "must be a marker id >= 0");
  r.get_path("map", s.map, base, true);
  s.mount = read_camera_mount(r);
  read_localise_options(r, s.localise);
  r.get_number("map_sigma", s.map_sigma_m, 0, false);
  if (s.map_sigma_m > 1.0) r.fail(n["map_sigma"], r.key("map_sigma"), "must be <= 1 m");
  r.finish();
  return s;
}

}  // namespace ips::config_detail
