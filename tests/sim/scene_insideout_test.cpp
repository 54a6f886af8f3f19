// A camera that rides on a robot and looks up, and markers printed face down on the ceiling
// (docs/simulator.md, docs/inside-out.md): where they are, pinned by hand-computed values.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>

#include "ips/core/error.h"
#include "ips/sim/ceiling.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"

namespace fs = std::filesystem;

namespace {

const std::string kIntr = std::string(IPS_TEST_DATA_DIR) + "/ou2023/intrinsics_red.yaml";

fs::path write_scene(const std::string& name, const std::string& body) {
  const fs::path dir = fs::temp_directory_path() / "ips_scene_insideout_test";
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << body;
  return p;
}

const std::string kScene = "cameras:\n  - name: up\n    intrinsics: " + kIntr +
                           "\n    looking: up\n    position: [0.3]\n    rotation_deg: [0, 0, 90]\n"
                           "    trajectory: {type: circle, center: [4, 3], radius: 2, speed: 1}\n"
                           "markers:\n  - {id: 5, length: 0.25, x: 4, y: 3, height: 2.8, yaw_deg: 30, facing: down}\n";

TEST(SceneInsideOut, ARidingCameraFollowsItsRobotWithItsMount) {
  const auto scene = ips::sim::Scene::load(write_scene("ride.yaml", kScene));
  // Circle: at t = 0 at centre + (r, 0) heading +y; after a quarter turn (pi r / 2 / speed s)
  // at centre + (0, r) heading -x.
  const double quarter = std::numbers::pi * 2.0 / 2.0;
  const auto p0 = scene.carrier_pose_at(0, 0.0), p1 = scene.carrier_pose_at(0, quarter);
  EXPECT_NEAR(p0.x, 6.0, 1e-9);
  EXPECT_NEAR(p0.y, 3.0, 1e-9);
  EXPECT_NEAR(p0.z, 0.3, 1e-12);
  EXPECT_NEAR(p0.yaw, std::numbers::pi / 2, 1e-9);
  EXPECT_NEAR(p1.x, 4.0, 1e-9);
  EXPECT_NEAR(p1.y, 5.0, 1e-9);
  EXPECT_NEAR(std::abs(p1.yaw), std::numbers::pi, 1e-9);
  // Looking up with the mount turned 90 degrees: image x = the robot's left. At t = 0 the
  // robot heads +y, so its left is -x: camera x = (-1, 0, 0), optical axis = +z.
  const auto cam = scene.camera_at(0, 0.0);
  EXPECT_LT((cam.R_wc.col(0) - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-9);
  EXPECT_LT((cam.R_wc.col(2) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-9);
  EXPECT_LT((cam.position - Eigen::Vector3d(6, 3, 0.3)).norm(), 1e-9);
}

TEST(SceneInsideOut, ACeilingMarkerIsSeenFromBelowAsPrinted) {
  const auto scene = ips::sim::Scene::load(write_scene("ride.yaml", kScene));
  const auto map = ips::sim::ceiling_map(scene);
  ASSERT_EQ(map.markers.size(), 1u);
  EXPECT_EQ(map.markers[0].id, 5);
  EXPECT_NEAR(map.markers[0].yaw, 30 * std::numbers::pi / 180, 1e-12);
  EXPECT_EQ(map.markers[0].centre, Eigen::Vector3d(4, 3, 2.8));
  // The renderer's exact corners of the marker are the map's corners projected: the
  // simulator and the map agree on which way a face-down marker reads.
  const ips::sim::CameraRenderer renderer(scene, 0);
  const double t = 1.0;
  const auto truth = renderer.truth(t);
  ASSERT_EQ(truth.size(), 1u);
  ASSERT_TRUE(truth[0].visible);
  const auto cam = scene.camera_at(0, t);
  const auto corners = map.markers[0].corners();
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d pc = cam.world_to_camera(corners[k]);
    const auto px = cam.model.project({pc.x() / pc.z(), pc.y() / pc.z()});
    EXPECT_NEAR(px.x, truth[0].corners_px[k].x, 1e-6);
    EXPECT_NEAR(px.y, truth[0].corners_px[k].y, 1e-6);
  }
  // Corners go clockwise in the image (TL, TR, BR, BL as printed, y down): not mirrored.
  double area2 = 0;
  for (int k = 0; k < 4; ++k) {
    const auto& a = truth[0].corners_px[k];
    const auto& b = truth[0].corners_px[(k + 1) % 4];
    area2 += a.x * b.y - b.x * a.y;
  }
  EXPECT_GT(area2, 0);
}

// A lamp is drawn where its disc is: the pixel under its centre saturates, the ceiling beside
// the glow keeps the plain grey, and a camera looking down never sees it.
TEST(SceneInsideOut, ALampIsDrawnOnTheCeilingWhereItIs) {
  const auto scene = ips::sim::Scene::load(write_scene(
      "lamp.yaml", kScene + "render: {noise_sigma: 0, vignetting: 0}\nlamps:\n  - {x: 6, y: 3, height: 2.8, "
                            "radius: 0.2, glare: 0.2, glare_width: 0.3}\n"));
  ASSERT_EQ(scene.lamps.size(), 1u);
  EXPECT_DOUBLE_EQ(scene.lamps[0].brightness, 255.0);
  const ips::sim::CameraRenderer renderer(scene, 0);
  cv::Mat gray;
  renderer.render(0.0, gray, 0);  // the robot at (6, 3): the lamp is straight above the lens
  const ips::sim::SceneCamera cam = scene.camera_at(0, 0.0);
  const auto pixel_of = [&](double x, double y) {
    const Eigen::Vector3d pc = cam.world_to_camera({x, y, 2.8});
    const ips::Point2 px = cam.model.project({pc.x() / pc.z(), pc.y() / pc.z()});
    return gray.at<std::uint8_t>(static_cast<int>(std::lround(px.y)), static_cast<int>(std::lround(px.x)));
  };
  EXPECT_EQ(pixel_of(6.0, 3.0), 255);
  EXPECT_EQ(pixel_of(6.15, 3.0), 255) << "inside the disc";
  const int rim = pixel_of(6.22, 3.0), far = pixel_of(6.8, 3.0);
  EXPECT_NEAR(far, 170, 2) << "beyond the glow: the plain ceiling";
  EXPECT_NEAR(rim, 170 + 0.2 * 255 * (1 - 0.02 / 0.3), 4) << "the glow near the rim";
}

TEST(SceneInsideOut, MistakesAreNamed) {
  const std::string cam = "cameras:\n  - name: up\n    intrinsics: " + kIntr + "\n";
  struct Case {
    const char* file;
    std::string body;
    const char* expect;
  } cases[] = {
      {"looking.yaml", cam + "    looking: sideways\n    position: [1, 1, 2]\n",
       "cameras[0].looking: expected down or up"},
      {"ride_pos.yaml",
       cam + "    looking: up\n    position: [1, 2]\n    trajectory: {type: circle, center: [1, 1], "
             "radius: 1, speed: 1}\n",
       "cameras[0].position: a riding camera takes [height] or [x, y, height]"},
      {"ride_place.yaml",
       cam + "    looking: up\n    position: [0.3]\n    trajectory: {type: placements, control: c.txt, points: [[1, "
             "1]]}\n",
       "not placements"},
      {"lamp_both.yaml", kScene + "lamps:\n  - {x: 1, y: 1, height: 2.8, radius: 0.2, size: [1, 1]}\n",
       "lamps[0].radius: a lamp is a disc (radius) or a panel (size), not both"},
      {"lamp_none.yaml", kScene + "lamps:\n  - {x: 1, y: 1, height: 2.8}\n", "lamps[0].radius: missing"},
      {"lamp_bright.yaml", kScene + "lamps:\n  - {x: 1, y: 1, height: 2.8, radius: 0.2, brightness: 300}\n",
       "lamps[0].brightness: must be 0..255"},
      {"lamp_key.yaml", kScene + "lamps:\n  - {x: 1, y: 1, height: 2.8, radius: 0.2, glow: 1}\n", "lamps[0].glow"},
      {"facing.yaml", cam + "    position: [1, 1, 2]\nmarkers:\n  - {id: 1, x: 1, y: 1, facing: left}\n",
       "markers[0].facing: expected up or down"},
      {"facing_moving.yaml",
       cam + "    position: [1, 1, 2]\nmarkers:\n  - {id: 1, facing: down, trajectory: {type: circle, center: [1, 1], "
             "radius: 1, speed: 1}}\n",
       "a marker facing down is fixed"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    try {
      ips::sim::Scene::load(write_scene(c.file, c.body));
      ADD_FAILURE() << "accepted";
    } catch (const ips::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
}

}  // namespace
