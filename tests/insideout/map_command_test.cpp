// `ips map` end to end: a simulated drive under the 24-marker ceiling of
// config/scenes/insideout_lab.yaml, mapped from its frames and two references, against the
// simulator's exact map; then localised against the map it built; bad references exit 2.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <gtest/gtest.h>

#include "command.h"
#include "ips/insideout/ceiling_map.h"

namespace fs = std::filesystem;

namespace {

const std::string kScene = std::string(IPS_CONFIG_DIR) + "/scenes/insideout_lab.yaml";
const std::string kLens = std::string(IPS_TEST_DATA_DIR) + "/ou2023/intrinsics_red.yaml";

class MapCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("ips_map_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "robot.yaml") << "camera:\n  intrinsics: " << kLens << "\n";
    // 20 s at 2 fps: 40 frames, 2.4 laps of the circle.
    const auto sim = ips::test::run_program(
        "ips", "sim drive --scene " + kScene + " --camera up --seconds 20 --fps 2 --out " + (dir_ / "drive").string());
    ASSERT_EQ(sim.status, 0) << sim.out;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static ips::test::CommandResult map(const std::string& refs, const std::string& out) {
    std::ofstream(dir_ / "refs.yaml") << refs;
    return ips::test::run_program("ips", "map --images " + (dir_ / "drive").string() + " --config " +
                                             (dir_ / "robot.yaml").string() + " --refs " +
                                             (dir_ / "refs.yaml").string() + " --marker-length 0.25 --out " + out);
  }
  static fs::path dir_;
};
fs::path MapCommand::dir_;

void expect_close_to_truth(const ips::CeilingMap& built, const ips::CeilingMap& truth, double tol_m, double tol_rad) {
  ASSERT_EQ(built.markers.size(), truth.markers.size());
  for (const auto& m : built.markers) {
    const ips::CeilingMarker* t = truth.find(m.id);
    ASSERT_NE(t, nullptr) << m.id;
    EXPECT_LT((m.centre - t->centre).norm(), tol_m) << "marker " << m.id;
    EXPECT_LT(std::abs(std::remainder(m.yaw - t->yaw, 2 * M_PI)), tol_rad) << "marker " << m.id;
    EXPECT_EQ(m.length, 0.25);
  }
}

TEST_F(MapCommand, TwoReferenceCentresPlaceAMapWithinAMillimetreOfTheTruth) {
  const std::string out = (dir_ / "map.json").string();
  const auto r = map("references:\n  - {id: 0, x: 1.0, y: 0.9, z: 2.8}\n  - {id: 23, x: 7.0, y: 5.1, z: 2.8}\n", out);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("24 markers from 40 of 40 frames"), std::string::npos) << r.out;
  const auto truth = ips::CeilingMap::load(dir_ / "drive/map.json");
  // Every marker's uncertainty relative to the held one (marker 0, sigma 0): positive, at most
  // 1.3 mm here (measured; mostly how well the held marker's own heading is known, times the
  // distance), and larger far from it (marker 23, 7.2 m away) than beside it (marker 1, 1.2 m).
  const auto built = ips::CeilingMap::load(out);
  for (const auto& m : built.markers) {
    ASSERT_TRUE(m.sigma.has_value()) << m.id;
    const double s2 = std::hypot((*m.sigma)[0], (*m.sigma)[1]);
    if (m.id == 0)
      EXPECT_EQ(s2, 0.0);
    else
      EXPECT_TRUE(s2 > 0 && s2 < 0.003) << "marker " << m.id << ": " << s2;
  }
  EXPECT_GT((*built.find(23)->sigma).head<2>().norm(), (*built.find(1)->sigma).head<2>().norm());
  EXPECT_NE(r.out.find("uncertainty relative to marker 0 (held)"), std::string::npos) << r.out;
  // Measured on 300 frames: mean 0.04 mm, max 0.10 mm, yaw 0.02 deg.
  expect_close_to_truth(ips::CeilingMap::load(out), truth, 0.001, 0.2 * M_PI / 180);
  // The robot localised against the map it built: as against the exact one.
  const auto loc = ips::test::run_program(
      "ips", "localise --map " + out + " --config " + (dir_ / "robot.yaml").string() + " --images " +
                 (dir_ / "drive").string() + " --out " + (dir_ / "poses.csv").string());
  ASSERT_EQ(loc.status, 0) << loc.out;
  const auto score = ips::test::run_program(
      "ips", "score --estimate " + (dir_ / "poses.csv").string() + " --truth " + (dir_ / "drive/truth.csv").string());
  ASSERT_EQ(score.status, 0) << score.out;
  EXPECT_NE(score.out.find("     0        40        40     100.0%"), std::string::npos) << score.out;
}

TEST_F(MapCommand, OneReferenceWithItsYawIsEnough) {
  const std::string out = (dir_ / "map_yaw.json").string();
  // Marker 9 of the scene: x 4.6, y 2.3, yaw_deg (9 * 37) % 360 - 180 = 153.
  const auto r = map("references:\n  - {id: 9, x: 4.6, y: 2.3, z: 2.8, yaw_deg: 153}\n", out);
  ASSERT_EQ(r.status, 0) << r.out;
  // One marker's heading turns the whole map: 0.02 deg of it moves a marker 5 m away 1.7 mm.
  expect_close_to_truth(ips::CeilingMap::load(out), ips::CeilingMap::load(dir_ / "drive/map.json"), 0.004,
                        0.2 * M_PI / 180);
}

TEST_F(MapCommand, ReferencesThatCannotPlaceTheMapExitTwoAndWriteNothing) {
  const std::string out = (dir_ / "never.json").string();
  auto r = map("references:\n  - {id: 0, x: 1.0, y: 0.9, z: 2.8}\n", out);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find(">= 2 markers' centres, or one with its yaw"), std::string::npos) << r.out;
  r = map("references:\n  - {id: 0, x: 1.0, y: 0.9}\n  - {id: 77, x: 7.0, y: 5.1}\n", out);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("refs.yaml: reference 77: no frame of the drive placed it"), std::string::npos) << r.out;
  r = map("references:\n  - {id: 0, x: 1.0, y: 0.9, heading: 3}\n", out);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("unknown key 'heading'"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
