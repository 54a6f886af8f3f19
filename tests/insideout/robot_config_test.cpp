// robot.yaml read strictly: values land where they belong, mistakes are named with their place.
#include <gtest/gtest.h>

#include "ips/core/error.h"
#include "ips/insideout/robot_config.h"

namespace ips {
namespace {

const std::filesystem::path kHere = std::filesystem::path(IPS_TEST_DATA_DIR) / "ou2023" / "robot.yaml";

TEST(RobotConfig, ReadsTheCameraItsMountAndTheSolversSettings) {
  const RobotCameraConfig c = parse_robot_config(R"(
camera:
  intrinsics: intrinsics_red.yaml
  mount:
    offset: [0.10, -0.02, 0.25]
    yaw_deg: 90
    pitch_deg: 2
detection:
  min_marker_px: 20
localise:
  pixel_sigma: 0.3
  outlier_px: 2
  tilt_sigma_deg: 0.5
)",
                                                 kHere);
  EXPECT_EQ(c.intrinsics, kHere.parent_path() / "intrinsics_red.yaml");
  EXPECT_EQ(c.mount.offset, Eigen::Vector3d(0.10, -0.02, 0.25));
  EXPECT_NEAR(c.mount.yaw, M_PI / 2, 1e-12);
  EXPECT_NEAR(c.mount.pitch, 2 * M_PI / 180, 1e-12);
  EXPECT_EQ(c.mount.roll, 0.0);
  EXPECT_EQ(c.detection.min_marker_px, 20);
  EXPECT_EQ(c.localise.pixel_sigma, 0.3);
  EXPECT_EQ(c.localise.outlier_px, 2);
  EXPECT_NEAR(c.localise.tilt_sigma, 0.5 * M_PI / 180, 1e-12);
  // The defaults: lens at the origin looking up, image x forward, a floor level within 1 degree.
  const RobotCameraConfig d = parse_robot_config("camera: {intrinsics: intrinsics_red.yaml}\n", kHere);
  EXPECT_EQ(d.mount.offset, Eigen::Vector3d::Zero());
  EXPECT_TRUE(d.mount.camera_axes().isIdentity(1e-15));
  EXPECT_NEAR(d.localise.tilt_sigma, M_PI / 180, 1e-12);
}

void expect_refused(const std::string& yaml, const std::string& part) {
  try {
    parse_robot_config(yaml, kHere);
    ADD_FAILURE() << "accepted: " << yaml;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(RobotConfig, MistakesAreNamedWithFileLineAndKey) {
  expect_refused("camera: {intrinsics: nowhere.yaml}\n", "camera.intrinsics: no such file");
  expect_refused("localise: {pixel_sigma: 0.5}\n", "camera: required key is missing");
  expect_refused("camera:\n  intrinsics: intrinsics_red.yaml\n  mount: {ofset: [0, 0, 0]}\n",
                 "robot.yaml:3:11: camera.mount.ofset: unknown key");
  expect_refused("camera:\n  intrinsics: intrinsics_red.yaml\n  mount: {offset: [0, 0]}\n",
                 "camera.mount.offset: expected [x, y, z]");
  expect_refused("camera:\n  intrinsics: intrinsics_red.yaml\n  mount: {pitch_deg: 80}\n", "within +-60");
  expect_refused("camera: {intrinsics: intrinsics_red.yaml}\nlocalise: {pixel_sigma: 0}\n",
                 "localise.pixel_sigma: must be > 0");
  expect_refused("camera: {intrinsics: intrinsics_red.yaml}\ncolour: red\n", "colour: unknown key");
  EXPECT_THROW(load_robot_config("/nonexistent/robot.yaml"), InputError);
}

}  // namespace
}  // namespace ips
