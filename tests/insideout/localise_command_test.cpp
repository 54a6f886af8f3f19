// The inside-out commands end to end, as a user runs them: `ips sim drive` writes a drive
// (frames, times.csv, truth.csv, map.json), `ips localise` places the robot in every frame, its
// t_ns echoed exactly; an `ips record` session of the same camera gives the same poses; bad
// input exits 2 naming the file, and nothing is written.
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "command.h"
#include "ips/geometry/camera_model.h"
#include "ips/sim/renderer.h"
#include "ips/survey/survey.h"

namespace fs = std::filesystem;

namespace ips {
namespace {

const std::string kScene = std::string(IPS_CONFIG_DIR) + "/scenes/insideout_lab.yaml";
const std::string kLens = std::string(IPS_TEST_DATA_DIR) + "/ou2023/intrinsics_red.yaml";

struct Row {
  double x, y, z, yaw;
};

// t_ns -> row of a CSV whose first five columns are t_ns,x,y,z,yaw.
std::map<long long, Row> read_poses(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::map<long long, Row> out;
  while (std::getline(in, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream s(line);
    long long t = 0;
    Row r{};
    s >> t >> r.x >> r.y >> r.z >> r.yaw;
    out[t] = r;
  }
  return out;
}

class LocaliseCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ips_localise_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "robot.yaml") << "camera:\n  intrinsics: " << kLens << "\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(LocaliseCommand, ADriveRenderedAndLocalisedMatchesItsTruth) {
  const auto sim = test::run_program(
      "ips", "sim drive --scene " + kScene + " --camera up --seconds 2 --fps 5 --out " + (dir_ / "drive").string());
  ASSERT_EQ(sim.status, 0) << sim.out;
  const auto run = test::run_program("ips", "localise --map " + (dir_ / "drive/map.json").string() + " --config " +
                                                (dir_ / "robot.yaml").string() + " --images " +
                                                (dir_ / "drive").string() + " --out " + (dir_ / "poses.csv").string());
  ASSERT_EQ(run.status, 0) << run.out;
  EXPECT_NE(run.out.find("10 of 10 frames placed the robot"), std::string::npos) << run.out;
  std::ifstream header(dir_ / "poses.csv");
  std::string first;
  std::getline(header, first);
  EXPECT_EQ(first, "t_ns,x,y,z,yaw,sx,sy,syaw,markers");
  const auto truth = read_poses(dir_ / "drive/truth.csv");
  const auto poses = read_poses(dir_ / "poses.csv");
  ASSERT_EQ(poses.size(), 10u);
  for (const auto& [t, p] : poses) {
    ASSERT_EQ(truth.count(t), 1u) << "t_ns " << t << " is not a frame's";  // echoed exactly
    const Row& q = truth.at(t);
    EXPECT_LT(std::hypot(p.x - q.x, p.y - q.y), 0.001) << "t_ns " << t;
    EXPECT_NEAR(p.z, 0.3, 0.002);
    EXPECT_LT(std::abs(std::remainder(p.yaw - q.yaw, 2 * M_PI)), 0.002);
  }
}

TEST_F(LocaliseCommand, ARecordedSessionOfTheCameraIsLocalisedToo) {
  // A session as `ips record` writes it, from the camera's exact corners at 4 instants.
  const sim::Scene scene = sim::Scene::load(kScene);
  const std::size_t cam = scene.camera_index("up");
  const sim::CameraRenderer renderer(scene, cam);
  survey::Session session;
  session.config = "robot.yaml";
  session.fingerprint = survey::camera_fingerprint({{"up", scene.cameras[cam].model}});
  session.dictionary = scene.dictionary;
  session.seconds = 1.5;
  session.cameras.push_back({"up", "up.det", {}});
  fs::create_directories(dir_ / "session");
  std::ofstream(dir_ / "session/session.txt") << survey::session_header(session);
  std::ofstream det(dir_ / "session/up.det");
  for (int k = 0; k < 4; ++k) {
    for (const auto& t : renderer.truth(0.5 * k)) {
      if (t.visible) det << survey::detection_line({500'000'000LL * k, t.id, t.corners_px}) << "\n";
    }
  }
  det.close();
  const auto sim = test::run_program(
      "ips", "sim drive --scene " + kScene + " --camera up --seconds 0.1 --fps 10 --out " + (dir_ / "drive").string());
  ASSERT_EQ(sim.status, 0) << sim.out;
  const auto run = test::run_program(
      "ips", "localise --map " + (dir_ / "drive/map.json").string() + " --config " + (dir_ / "robot.yaml").string() +
                 " --session " + (dir_ / "session").string() + " --out " + (dir_ / "poses.csv").string());
  ASSERT_EQ(run.status, 0) << run.out;
  const auto poses = read_poses(dir_ / "poses.csv");
  ASSERT_EQ(poses.size(), 4u);
  for (const auto& [t, p] : poses) {
    const sim::MarkerPose q = scene.carrier_pose_at(cam, static_cast<double>(t) * 1e-9);
    EXPECT_LT(std::hypot(p.x - q.x, p.y - q.y), 1e-4) << "t_ns " << t;  // exact corners
    EXPECT_LT(std::abs(std::remainder(p.yaw - q.yaw, 2 * M_PI)), 1e-4);
  }
  // The same session recorded with another calibration (another fingerprint): refused.
  session.fingerprint = "0123456789abcdef";
  std::ofstream(dir_ / "session/session.txt") << survey::session_header(session);
  fs::remove(dir_ / "poses.csv");
  const auto other = test::run_program(
      "ips", "localise --map " + (dir_ / "drive/map.json").string() + " --config " + (dir_ / "robot.yaml").string() +
                 " --session " + (dir_ / "session").string() + " --out " + (dir_ / "poses.csv").string());
  EXPECT_EQ(other.status, 2) << other.out;
  EXPECT_NE(other.out.find("fingerprint 0123456789abcdef is not camera 'up'"), std::string::npos) << other.out;
  EXPECT_FALSE(fs::exists(dir_ / "poses.csv"));
}

TEST_F(LocaliseCommand, BadInputExitsTwoNamingTheFileAndWritesNothing) {
  std::ofstream(dir_ / "map.json") << R"({"format": "ips-ceiling-map", "version": 1, "markers": [)"
                                   << R"({"id": 1, "x": 0, "y": 0, "z": 2.8, "yaw": 0, "length": -1}]})";
  fs::create_directories(dir_ / "frames");
  std::ofstream(dir_ / "frames/times.csv") << "file,t_ns\na.jpg,200\nb.jpg,100\n";
  const std::string out = (dir_ / "poses.csv").string();
  auto r = test::run_program("ips", "localise --map " + (dir_ / "map.json").string() + " --config " +
                                        (dir_ / "robot.yaml").string() + " --images " + (dir_ / "frames").string() +
                                        " --out " + out);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("map.json: markers[0].length"), std::string::npos) << r.out;
  std::ofstream(dir_ / "map.json") << R"({"format": "ips-ceiling-map", "version": 1, "markers": [)"
                                   << R"({"id": 1, "x": 0, "y": 0, "z": 2.8, "yaw": 0, "length": 0.2}]})";
  r = test::run_program("ips", "localise --map " + (dir_ / "map.json").string() + " --config " +
                                   (dir_ / "robot.yaml").string() + " --images " + (dir_ / "frames").string() +
                                   " --out " + out);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("times.csv:3: t_ns: not after the previous frame's"), std::string::npos) << r.out;
  r = test::run_program("ips", "localise --map " + (dir_ / "map.json").string() + " --config " +
                                   (dir_ / "robot.yaml").string() + " --out " + out);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--images DIR or --session DIR"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace ips
