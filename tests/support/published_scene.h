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

}  // namespace ips::test
