#include "ips/sim/scene.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "ips/core/error.h"

namespace fs = std::filesystem;

namespace {

const fs::path kData = IPS_TEST_DATA_DIR;
const fs::path kScene = fs::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml";

// Rigid (Kabsch) fit world = R cam + t over the published pairs of one camera.
void kabsch(const std::vector<Eigen::Vector3d>& cam, const std::vector<Eigen::Vector3d>& world, Eigen::Matrix3d& R,
            Eigen::Vector3d& t) {
  Eigen::Vector3d mc = Eigen::Vector3d::Zero(), mw = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < cam.size(); ++i) {
    mc += cam[i];
    mw += world[i];
  }
  mc /= static_cast<double>(cam.size());
  mw /= static_cast<double>(cam.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < cam.size(); ++i) H += (cam[i] - mc) * (world[i] - mw).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  R = svd.matrixV() * D * svd.matrixU().transpose();
  t = mw - R * mc;
}

TEST(Scene, PublishedLayoutAgreesWithRigidFitOfTrain40) {
  const auto scene = ips::sim::Scene::load(kScene);
  ASSERT_EQ(scene.cameras.size(), 3u);
  std::map<std::string, std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Vector3d>>> pairs;
  std::ifstream in(kData / "ou2023/train40.csv");
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string name, f;
    std::getline(ss, name, ',');
    double v[6];
    for (double& x : v) {
      std::getline(ss, f, ',');
      x = std::stod(f);
    }
    pairs[name].first.emplace_back(v[0], v[1], v[2]);
    pairs[name].second.emplace_back(v[3], v[4], v[5]);
  }
  for (const auto& cam : scene.cameras) {
    SCOPED_TRACE(cam.name);
    ASSERT_EQ(pairs[cam.name].first.size(), 40u);
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    kabsch(pairs[cam.name].first, pairs[cam.name].second, R, t);
    // The scene holds the fitted pose (to the millimetre and 0.01 degree) ...
    EXPECT_LT((t - cam.position).norm(), 0.005) << t.transpose();
    const double angle = Eigen::AngleAxisd(R.transpose() * cam.R_wc).angle();
    EXPECT_LT(angle, 0.05 * std::numbers::pi / 180) << angle;
    // ... which looks straight down to within 2 degrees.
    EXPECT_LT(Eigen::AngleAxisd(cam.R_wc.transpose() * ips::sim::Scene::orientation(0, 0, 0)).angle(),
              2.0 * std::numbers::pi / 180);
    EXPECT_EQ(cam.model.size().width, 1920);
  }
}

TEST(Scene, DefaultOrientationLooksStraightDown) {
  const Eigen::Matrix3d R = ips::sim::Scene::orientation(0, 0, 0);
  EXPECT_TRUE(R.col(0).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(R.col(1).isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d(0, 0, -1)));
}

TEST(Scene, TrajectoriesAreWhereTheyShouldBe) {
  const auto scene = ips::sim::Scene::load(kScene);
  // Circle, radius 1.2 around (2.4, 2.4) at 0.4 m/s: a quarter turn takes (pi/2 * 1.2) / 0.4 s.
  const double quarter = std::numbers::pi / 2 * 1.2 / 0.4;
  const auto p = scene.marker_pose(1, quarter);
  EXPECT_NEAR(p.x, 2.4, 1e-9);
  EXPECT_NEAR(p.y, 3.6, 1e-9);
  EXPECT_NEAR(p.z, 0.15, 1e-12);
  EXPECT_NEAR(std::remainder(p.yaw - std::numbers::pi, 2 * std::numbers::pi), 0.0,
              1e-9);  // heading -x
  // Line back and forth: from (1.2, 0.6) to (3.6, 4.2), length sqrt(2.4^2 + 3.6^2).
  const double len = std::hypot(2.4, 3.6);
  const auto end = scene.marker_pose(2, len / 0.3);
  EXPECT_NEAR(end.x, 3.6, 1e-9);
  EXPECT_NEAR(end.y, 4.2, 1e-9);
  const auto back = scene.marker_pose(2, 1.5 * len / 0.3);
  EXPECT_NEAR(back.x, 2.4, 1e-9);
  EXPECT_NEAR(back.y, 2.4, 1e-9);
  // Waypoints loop: perimeter 2 * (1.9 + 2.9) = 9.6 m at 0.5 m/s -> back at the start after 19.2 s.
  const auto loop = scene.marker_pose(3, 19.2 + 1.0);
  EXPECT_NEAR(loop.x, 2.0, 1e-9);
  EXPECT_NEAR(loop.y, 1.0, 1e-9);
  const auto fixed = scene.marker_pose(4, 100.0);
  EXPECT_NEAR(fixed.x, 2.9, 1e-12);
  EXPECT_NEAR(fixed.yaw, 30 * std::numbers::pi / 180, 1e-12);
  EXPECT_THROW(scene.marker_pose(99, 0.0), std::out_of_range);
}

fs::path write_scene(const std::string& name, const std::string& body) {
  const fs::path dir = fs::temp_directory_path() / "ips_scene_test";
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << body;
  return p;
}

// What docs/simulator.md's scene section promises a reader, each statement pinned down.
TEST(Scene, DocumentedTrajectoryConventions) {
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  const double deg = std::numbers::pi / 180;
  const auto scene = ips::sim::Scene::load(
      write_scene("conventions.yaml",
                  "cameras:\n  - name: red\n    intrinsics: " + intr +
                      "\n    position: [1, 1, 2]\n"
                      "markers:\n"
                      // 0: counter-clockwise circle, 1: clockwise, both with a 10 degree yaw offset
                      "  - {id: 0, yaw_deg: 10, height: 0.1,\n"
                      "     trajectory: {type: circle, center: [2, 2], radius: 1, speed: 0.5}}\n"
                      "  - {id: 1, yaw_deg: 10, trajectory: {type: circle, center: [2, 2], radius: 1, speed: 0.5,"
                      " clockwise: true}}\n"
                      // 2: a line (x/y given and ignored), 3: waypoints, 4: the same line without x/y
                      "  - {id: 2, x: 0.3, y: 0.4, trajectory: {type: line, from: [1, 1], to: [3, 1], speed: 1}}\n"
                      "  - {id: 3, trajectory: {type: waypoints, points: [[1, 1], [1, 3], [3, 3]], speed: 1}}\n"
                      "  - {id: 4, trajectory: {type: line, from: [1, 1], to: [3, 1], speed: 1}}\n"
                      "  - {id: 5, yaw_deg: 25, trajectory: {type: line, from: [1, 1], to: [3, 1], speed: 1,"
                      " heading: fixed}}\n"));
  auto heading = [](double yaw) { return std::remainder(yaw, 2 * std::numbers::pi); };
  // Circle at t = 0: at centre + (radius, 0); counter-clockwise moves towards +y (heading
  // +90 deg), clockwise towards -y; yaw_deg is added to the heading of travel.
  auto c = scene.marker_pose(0, 0.0);
  EXPECT_NEAR(c.x, 3.0, 1e-12);
  EXPECT_NEAR(c.y, 2.0, 1e-12);
  EXPECT_NEAR(c.z, 0.1, 1e-12);
  EXPECT_NEAR(heading(c.yaw - (90 + 10) * deg), 0.0, 1e-12);
  EXPECT_GT(scene.marker_pose(0, 0.1).y, 2.0);
  c = scene.marker_pose(1, 0.0);
  EXPECT_NEAR(c.x, 3.0, 1e-12);
  EXPECT_NEAR(heading(c.yaw - (-90 + 10) * deg), 0.0, 1e-12);
  EXPECT_LT(scene.marker_pose(1, 0.1).y, 2.0);
  // Line at t = 0: at `from`, heading towards `to`; x/y of the marker are ignored.
  auto l = scene.marker_pose(2, 0.0);
  EXPECT_NEAR(l.x, 1.0, 1e-12);
  EXPECT_NEAR(l.y, 1.0, 1e-12);
  EXPECT_NEAR(heading(l.yaw), 0.0, 1e-12);
  for (double t : {0.0, 0.7, 2.5, 3.9}) {
    EXPECT_EQ(scene.marker_pose(2, t).x, scene.marker_pose(4, t).x);
    EXPECT_EQ(scene.marker_pose(2, t).y, scene.marker_pose(4, t).y);
  }
  // The heading flips by 180 degrees at `to` (t = 2 s) and back at `from` (t = 4 s).
  EXPECT_NEAR(heading(scene.marker_pose(2, 1.99).yaw), 0.0, 1e-12);
  EXPECT_NEAR(scene.marker_pose(2, 2.01).x, 2.99, 1e-9);
  EXPECT_NEAR(std::abs(heading(scene.marker_pose(2, 2.01).yaw)), std::numbers::pi, 1e-12);
  EXPECT_NEAR(std::abs(heading(scene.marker_pose(2, 3.99).yaw)), std::numbers::pi, 1e-12);
  EXPECT_NEAR(heading(scene.marker_pose(2, 4.01).yaw), 0.0, 1e-12);
  EXPECT_NEAR(scene.marker_pose(2, 4.01).x, 1.01, 1e-9);
  // heading: fixed keeps yaw_deg whatever the direction of travel.
  EXPECT_NEAR(scene.marker_pose(5, 3.0).yaw, 25 * deg, 1e-12);
  // Waypoints at t = 0: at the first point heading to the second; a closed loop (the last
  // point leads back to the first).
  auto w = scene.marker_pose(3, 0.0);
  EXPECT_NEAR(w.x, 1.0, 1e-12);
  EXPECT_NEAR(w.y, 1.0, 1e-12);
  EXPECT_NEAR(heading(w.yaw - 90 * deg), 0.0, 1e-12);
  const double loop = 2 + 2 + std::hypot(2.0, 2.0);
  w = scene.marker_pose(3, loop - 0.5);  // on the closing leg (3, 3) -> (1, 1)
  EXPECT_NEAR(heading(w.yaw + 135 * deg), 0.0, 1e-12);
  EXPECT_NEAR(scene.marker_pose(3, loop + 0.5).y, 1.5, 1e-9);
}

// rotation_deg: [roll, pitch, yaw] turn the straight-down camera about the WORLD x axis by
// roll, then about the world y axis by pitch, then about the world z axis by yaw:
// R_wc = Rz(yaw) Ry(pitch) Rx(roll) R_down. Axes worked out by hand below.
TEST(Scene, RotationDegOrderAndSigns) {
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  auto camera = [&](const std::string& rot) {
    return ips::sim::Scene::load(write_scene("rot.yaml", "cameras:\n  - name: red\n    intrinsics: " + intr +
                                                             "\n    position: [1, 1, 2]\n    rotation_deg: " + rot +
                                                             "\n"))
        .cameras[0]
        .R_wc;
  };
  // Roll 90 first turns the optical axis from -z to +y and image y to -z; yaw 90 then turns
  // about z: image x -> +y, image y stays -z, optical axis -> -x. (Yaw first, then roll,
  // would give an optical axis along +y.)
  Eigen::Matrix3d R = camera("[90, 0, 90]");
  EXPECT_TRUE(R.col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12)) << R;
  EXPECT_LT((R.col(1) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-12) << R;
  EXPECT_LT((R.col(2) - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-12) << R;
  // Signs: +roll tilts the view towards +y, +pitch towards -x, +yaw turns image x from +x to +y.
  const double s = std::sin(10 * std::numbers::pi / 180), c = std::cos(10 * std::numbers::pi / 180);
  EXPECT_LT((camera("[10, 0, 0]").col(2) - Eigen::Vector3d(0, s, -c)).norm(), 1e-12);
  EXPECT_LT((camera("[0, 10, 0]").col(2) - Eigen::Vector3d(-s, 0, -c)).norm(), 1e-12);
  EXPECT_LT((camera("[0, 0, 10]").col(0) - Eigen::Vector3d(c, s, 0)).norm(), 1e-12);
}

// placements: the marker sits at the pose whose index the control file holds; anything else
// there means it was picked up. Poses default to the marker's height and yaw_deg.
TEST(Scene, PlacementsFollowTheControlFile) {
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  const fs::path scene_file = write_scene(
      "placements.yaml", "cameras:\n  - name: red\n    intrinsics: " + intr +
                             "\n    position: [1, 1, 2]\n"
                             "markers:\n  - {id: 0, height: 0.05, yaw_deg: 30, trajectory: {type: placements, "
                             "control: placement_index.txt, points: [[1, 2], [2, 3, 0.15], [0.5, 0.25, 0, -90]]}}\n");
  const fs::path control = scene_file.parent_path() / "placement_index.txt";
  fs::remove(control);
  const auto scene = ips::sim::Scene::load(scene_file);
  EXPECT_FALSE(scene.marker_pose(0, 0.0).present);  // no file yet
  std::ofstream(control) << "1\n";
  auto p = scene.marker_pose(0, 5.0);
  EXPECT_TRUE(p.present);
  EXPECT_EQ(p.x, 2.0);
  EXPECT_EQ(p.y, 3.0);
  EXPECT_EQ(p.z, 0.15);
  EXPECT_NEAR(p.yaw, 30 * std::numbers::pi / 180, 1e-12);
  std::ofstream(control) << "0";
  p = scene.marker_pose(0, 0.0);
  EXPECT_EQ(p.x, 1.0);
  EXPECT_EQ(p.z, 0.05);
  std::ofstream(control) << "2";
  EXPECT_NEAR(scene.marker_pose(0, 0.0).yaw, -std::numbers::pi / 2, 1e-12);
  EXPECT_EQ(scene.marker_pose(0, 0.0).z, 0.0);
  for (const char* bad : {"3", "-1", "x", "1 2", ""}) {
    std::ofstream(control) << bad;
    EXPECT_FALSE(scene.marker_pose(0, 0.0).present) << "'" << bad << "'";
  }
  fs::remove(control);
}

TEST(Scene, BadScenesNameFileLineAndKey) {
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  const std::string cam = "cameras:\n  - name: red\n    intrinsics: " + intr + "\n    position: [1, 1, 2]\n";
  struct Case {
    const char* file;
    std::string body;
    const char* expect;
  } cases[] = {
      {"no_cameras.yaml", "floor: {size: [4, 4]}\n", "cameras"},
      // A mapping as a key (found by fuzz_scene, tests/fuzz/scene/complex_key.yaml).
      {"complex_key.yaml", cam + "floor:\n  ? size: [4, 4]\n  : 1\n", "a key must be a plain word"},
      {"typo.yaml", cam + "flor: {size: [4, 4]}\n", "flor"},
      {"bad_size.yaml", cam + "floor: {size: [4, -1]}\n", "floor.size"},
      {"bad_intr.yaml", "cameras:\n  - name: red\n    intrinsics: missing.yaml\n    position: [1, 1, 2]\n",
       "cameras[0].intrinsics"},
      {"bad_pos.yaml", "cameras:\n  - name: red\n    intrinsics: " + intr + "\n    position: [1, x, 2]\n",
       "cameras[0].position"},
      {"dup_cam.yaml", cam + "  - name: red\n    intrinsics: " + intr + "\n    position: [1, 1, 2]\n", "duplicate"},
      {"bad_traj.yaml", cam + "markers:\n  - id: 1\n    trajectory: {type: spiral, speed: 1}\n",
       "markers[0].trajectory.type"},
      {"bad_radius.yaml",
       cam + "markers:\n  - id: 1\n    trajectory: {type: circle, center: [1, 1], radius: -2, "
             "speed: 1}\n",
       "radius"},
      {"no_xy.yaml", cam + "markers:\n  - id: 1\n    length: 0.2\n", "markers[0].x"},
      {"bad_id.yaml", cam + "markers:\n  - {id: 100, x: 1, y: 1}\n", "markers[0].id"},
      {"bad_dict.yaml", "dictionary: DICT_9X9\n" + cam, "dictionary"},
      {"bad_quality.yaml", cam + "render: {jpeg_quality: 101}\n", "render.jpeg_quality"},
      // Numbers beyond the integer's range were cast undefinedly (found by fuzz_scene,
      // tests/fuzz/scene/floor_seed_overflow.yaml).
      {"big_seed.yaml", cam + "floor:\n  seed: 1e49\n",
       "big_seed.yaml:6: floor.seed: must be an integer in 0..4294967295"},
      {"big_render_seed.yaml", cam + "render: {seed: -1}\n", "render.seed: must be an integer"},
      {"big_supersample.yaml", cam + "render: {supersample: 1e300}\n",
       "render.supersample: must be an integer in 1..8"},
      {"big_id.yaml", cam + "markers:\n  - {id: 1e300, x: 1, y: 1}\n", "markers[0].id"},
      {"broken.yaml", cam + "markers: [\n", "YAML"},
      {"no_control.yaml", cam + "markers:\n  - {id: 1, trajectory: {type: placements, points: [[1, 1]]}}\n",
       "markers[0].trajectory.control"},
      {"bad_placement.yaml",
       cam + "markers:\n  - {id: 1, trajectory: {type: placements, control: c.txt, points: "
             "[[1, 1, -0.1]]}}\n",
       "markers[0].trajectory.points[0]"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    try {
      ips::sim::Scene::load(write_scene(c.file, c.body));
      ADD_FAILURE() << "accepted";
    } catch (const ips::InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(c.expect), std::string::npos) << msg;
      EXPECT_NE(msg.find(c.file), std::string::npos) << msg;
    }
  }
  EXPECT_THROW(ips::sim::Scene::load("/nonexistent/scene.yaml"), ips::InputError);
}

}  // namespace
