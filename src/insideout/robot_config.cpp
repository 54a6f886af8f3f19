#include "ips/insideout/robot_config.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "core/map_reader.h"
#include "detect/parse_detection.h"
#include "insideout/parse_robot_camera.h"
#include "ips/core/error.h"

namespace ips {

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
    if (cam.has("mount")) {
      config_detail::MapReader mount(cam.node("mount"), "camera.mount", file);
      c.mount = config_detail::read_camera_mount(mount);
      mount.finish();
    }
    cam.finish();
  }
  if (top.has("detection")) {
    TrackerOptions unused;  // one photograph at a time: nothing is tracked
    c.detection = config_detail::parse_detection(top.node("detection"), file, unused);
  }
  if (top.has("localise")) {
    config_detail::MapReader l(top.node("localise"), "localise", file);
    config_detail::read_localise_options(l, c.localise);
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
