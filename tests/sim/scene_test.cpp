#include "ips/sim/scene.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "ips/error.h"

namespace fs = std::filesystem;

namespace {

const fs::path kData = IPS_TEST_DATA_DIR;
const fs::path kScene = fs::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml";

// Rigid (Kabsch) fit world = R cam + t over the published pairs of one camera.
void kabsch(const std::vector<Eigen::Vector3d>& cam, const std::vector<Eigen::Vector3d>& world,
            Eigen::Matrix3d& R, Eigen::Vector3d& t) {
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
  std::map<std::string, std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Vector3d>>>
      pairs;
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
    EXPECT_LT(
        Eigen::AngleAxisd(cam.R_wc.transpose() * ips::sim::Scene::orientation(0, 0, 0)).angle(),
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

TEST(Scene, BadScenesNameFileLineAndKey) {
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  const std::string cam =
      "cameras:\n  - name: red\n    intrinsics: " + intr + "\n    position: [1, 1, 2]\n";
  struct Case {
    const char* file;
    std::string body;
    const char* expect;
  } cases[] = {
      {"no_cameras.yaml", "floor: {size: [4, 4]}\n", "cameras"},
      {"typo.yaml", cam + "flor: {size: [4, 4]}\n", "flor"},
      {"bad_size.yaml", cam + "floor: {size: [4, -1]}\n", "floor.size"},
      {"bad_intr.yaml",
       "cameras:\n  - name: red\n    intrinsics: missing.yaml\n    position: [1, 1, 2]\n",
       "cameras[0].intrinsics"},
      {"bad_pos.yaml",
       "cameras:\n  - name: red\n    intrinsics: " + intr + "\n    position: [1, x, 2]\n",
       "cameras[0].position"},
      {"dup_cam.yaml",
       cam + "  - name: red\n    intrinsics: " + intr + "\n    position: [1, 1, 2]\n", "duplicate"},
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
      {"broken.yaml", cam + "markers: [\n", "YAML"},
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
