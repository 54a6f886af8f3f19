// cameras[].on_robot (docs/configuration.md, "A camera on a robot"): what it reads, its
// defaults, a daemon of robot cameras alone without a model file, and each mistake refused
// with the file, line and key.
#include <cmath>

#include "config_scratch.h"

namespace ips {
namespace {

class OnRobotConfig : public test::ConfigScratch {
 protected:
  void SetUp() override {
    ConfigScratch::SetUp();
    std::ofstream(dir_ / "map.json") << "{}";  // must exist; ipsd reads it (pipeline.cpp)
  }
  static std::string with(const std::string& on_robot, const std::string& rest = "model_file: model.json\n") {
    return "cameras:\n  - {name: red, source: synthetic, scene: scene.yaml}\n"
           "  - name: up\n    source: synthetic\n    scene: scene.yaml\n    on_robot: " +
           on_robot + "\n" + rest;
  }
};

TEST_F(OnRobotConfig, ReadsTheRobotItsMapAndTheMountWithDefaults) {
  const DaemonConfig c = parse_text(with("{marker: 7, map: map.json}"));
  ASSERT_EQ(c.on_robot.size(), 1u);
  EXPECT_FALSE(c.on_robot.contains(0)) << "the overhead camera";
  const OnRobotSettings& s = c.on_robot.at(1);
  EXPECT_EQ(s.marker, 7);
  EXPECT_EQ(s.map, dir_ / "map.json") << "relative to ipsd.yaml";
  EXPECT_EQ(s.mount, CameraMount{}) << "lens at the robot's origin, looking up, image +x forward";
  EXPECT_EQ(s.localise, LocaliseOptions{});
  EXPECT_DOUBLE_EQ(s.map_sigma_m, 0.01);

  const OnRobotSettings t = parse_text(with("{marker: 7, map: map.json, offset: [0.1, 0, 0.25], yaw_deg: 90, "
                                            "roll_deg: 2, pixel_sigma: 0.3, outlier_px: 5, tilt_sigma_deg: 0, "
                                            "map_sigma: 0.002}"))
                                .on_robot.at(1);
  EXPECT_EQ(t.mount.offset, Eigen::Vector3d(0.1, 0, 0.25));
  EXPECT_NEAR(t.mount.yaw, M_PI / 2, 1e-12);
  EXPECT_NEAR(t.mount.roll, 2 * M_PI / 180, 1e-12);
  EXPECT_DOUBLE_EQ(t.localise.pixel_sigma, 0.3);
  EXPECT_DOUBLE_EQ(t.localise.outlier_px, 5);
  EXPECT_DOUBLE_EQ(t.localise.tilt_sigma, 0);
  EXPECT_DOUBLE_EQ(t.map_sigma_m, 0.002);
}

TEST_F(OnRobotConfig, ADaemonOfRobotCamerasAloneNeedsNoModelFile) {
  const std::string robot_only =
      "cameras:\n  - name: up\n    source: synthetic\n    scene: scene.yaml\n    on_robot: {marker: 7, map: "
      "map.json}\n";
  EXPECT_TRUE(parse_text(robot_only).model_file.empty());
  expect_refused(with("{marker: 7, map: map.json}", ""), {"model_file", "required"});
}

TEST_F(OnRobotConfig, MistakesAreRefusedNamingTheKey) {
  expect_refused(with("{map: map.json}"), {"ipsd.yaml:", "cameras[1].on_robot.marker", "required"});
  expect_refused(with("{marker: -1, map: map.json}"), {"cameras[1].on_robot.marker", ">= 0"});
  expect_refused(with("{marker: 7}"), {"cameras[1].on_robot.map"});
  expect_refused(with("{marker: 7, map: nowhere.json}"), {"cameras[1].on_robot.map", "nowhere.json"});
  expect_refused(with("{marker: 7, map: map.json, ofset: [0, 0, 0]}"), {"cameras[1].on_robot.ofset", "unknown key"});
  expect_refused(with("{marker: 7, map: map.json, offset: [0, 0]}"), {"cameras[1].on_robot.offset", "[x, y, z]"});
  expect_refused(with("{marker: 7, map: map.json, pitch_deg: 75}"), {"cameras[1].on_robot", "+-60"});
  expect_refused(with("{marker: 7, map: map.json, pixel_sigma: 0}"), {"cameras[1].on_robot.pixel_sigma", "> 0"});
  expect_refused(with("{marker: 7, map: map.json, map_sigma: 5}"), {"cameras[1].on_robot.map_sigma", "<= 1 m"});
  expect_refused(with("7"), {"cameras[1].on_robot", "expected a mapping"});
}

}  // namespace
}  // namespace ips
