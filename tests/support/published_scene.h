// The published three-camera layout (config/scenes/ou2023.yaml) as scene text for tests that
// write their own scene file: the intrinsics paths made absolute, the scene's markers
// replaced by the test's own.
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace ips::test {

/// `markers_yaml` is the scene's new `markers:` section, starting with "markers:".
inline std::string published_scene_with(const std::string& markers_yaml) {
  std::ifstream in(std::string(IPS_CONFIG_DIR) + "/scenes/ou2023.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string scene = text.str();
  const std::string relative = "../../calib_data", absolute = IPS_TEST_DATA_DIR;
  for (auto at = scene.find(relative); at != std::string::npos; at = scene.find(relative, at + absolute.size()))
    scene.replace(at, relative.size(), absolute);
  return scene.substr(0, scene.find("\nmarkers:")) + "\n" + markers_yaml;
}

/// Two robots driving under the published cameras (marker 1 on a 1 m circle at 0.3 m/s, 0.15 m
/// up; marker 2 on a line at 0.25 m/s, 0.10 m up): the scene markers of the daemon suites.
inline const char* const kTwoMovingRobots = R"(markers:
  - id: 1
    length: 0.20
    height: 0.15
    trajectory: {type: circle, center: [2.4, 2.4], radius: 1.0, speed: 0.3}
  - id: 2
    length: 0.20
    height: 0.10
    trajectory: {type: line, from: [1.6, 1.2], to: [3.2, 3.6], speed: 0.25}
)";

}  // namespace ips::test
