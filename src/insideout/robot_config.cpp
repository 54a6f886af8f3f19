#include "ips/insideout/robot_config.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "core/map_reader.h"
#include "detect/parse_detection.h"
#include "ips/core/error.h"

namespace ips {
namespace {

constexpr double kRobotDeg = M_PI / 180.0;

CameraMount parse_camera_mount(const YAML::Node& n, const std::string& file) {
  config_detail::MapReader r(n, "camera.mount", file);
  CameraMount m;
  if (r.has("offset")) {
    const YAML::Node o = r.node("offset");
    if (!o.IsSequence() || o.size() != 3) r.fail(o, "camera.mount.offset", "expected [x, y, z] in metres");
    for (int i = 0; i < 3; ++i) {
      try {
        m.offset[i] = o[i].as<double>();
      } catch (const YAML::Exception&) {
        r.fail(o[i], "camera.mount.offset", "expected numbers");
      }
      if (!std::isfinite(m.offset[i])) r.fail(o[i], "camera.mount.offset", "not a finite number");
    }
  }
  double yaw = 0, roll = 0, pitch = 0;
  r.get("yaw_deg", yaw);
  r.get("roll_deg", roll);
  r.get("pitch_deg", pitch);
  if (std::abs(roll) > 60 || std::abs(pitch) > 60) {
    r.fail(n, "camera.mount", "roll_deg and pitch_deg must be within +-60 (the camera looks up)");
  }
  m.yaw = yaw * kRobotDeg;
  m.roll = roll * kRobotDeg;
  m.pitch = pitch * kRobotDeg;
  r.finish();
  return m;
}

}  // namespace

RobotCameraConfig parse_robot_config(const std::string& yaml_text, const std::filesystem::path& path) {
  const std::string file = path.string();
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError(file + ":" + std::to_string(e.mark.line + 1) + ": YAML error: " + e.msg);
  }
  RobotCameraConfig c;
  c.file = path;
  config_detail::MapReader top(root, "", file);
  if (!top.has("camera")) top.fail(root, "camera", "required key is missing");
  {
    config_detail::MapReader cam(top.node("camera"), "camera", file);
    cam.get_path("intrinsics", c.intrinsics, path.parent_path(), true);
    if (cam.has("mount")) c.mount = parse_camera_mount(cam.node("mount"), file);
    cam.finish();
  }
  if (top.has("detection")) {
    TrackerOptions unused;  // one photograph at a time: nothing is tracked
    c.detection = config_detail::parse_detection(top.node("detection"), file, unused);
  }
  if (top.has("localise")) {
    config_detail::MapReader l(top.node("localise"), "localise", file);
    l.get_number("pixel_sigma", c.localise.pixel_sigma, 0, true);
    l.get_number("outlier_px", c.localise.outlier_px, 0, true);
    double tilt_deg = c.localise.tilt_sigma / kRobotDeg;
    l.get_number("tilt_sigma_deg", tilt_deg, 0, false);
    c.localise.tilt_sigma = tilt_deg * kRobotDeg;
    l.finish();
  }
  top.finish();
  return c;
}

RobotCameraConfig load_robot_config(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open the robot configuration");
  std::stringstream s;
  s << in.rdbuf();
  return parse_robot_config(s.str(), path);
}

}  // namespace ips
