// `ips collect` run as the real program on simulated cameras, its standard input typed by the
// test: the marker is moved between placements through the scene's `placements` trajectory
// (the test writes the index of the current placement into the control file, then types).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "collect_session.h"
#include "ips/mapping/calib_data.h"
#include "ips/sim/scene.h"
#include "process_util.h"
#include "published_scene.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

// Three places in the red camera's view: [x, y, height, yaw_deg].
constexpr double kPlaces[3][4] = {{2.30, 1.00, 0.00, 0}, {2.00, 1.30, 0.10, 45}, {2.80, 0.70, 0.05, -30}};

class CollectCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ips_collect_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::string points;
    for (const auto& p : kPlaces)
      points += std::string(points.empty() ? "" : ", ") + "[" + std::to_string(p[0]) + ", " + std::to_string(p[1]) +
                ", " + std::to_string(p[2]) + ", " + std::to_string(p[3]) + "]";
    std::ofstream(dir_ / "scene.yaml") << test::published_scene_with(
        "markers:\n  - {id: 0, length: 0.20, trajectory: {type: placements, control: "
        "placement.txt, points: [" +
        points + "]}}\n");
    std::ofstream(dir_ / "moving.yaml") << test::published_scene_with(
        "markers:\n  - {id: 0, length: 0.20, trajectory: {type: circle, center: [2.3, 1.0], "
        "radius: 0.3, speed: 0.5}}\n");
    for (const char* scene : {"scene", "moving"})
      std::ofstream(dir_ / (std::string(scene) + ".ipsd.yaml"))
          << "cameras:\n  - {name: red, source: synthetic, scene: " << scene
          << ".yaml, fps: 10}\nmarkers: {edge_length: 0.20}\nmodel_file: model.json\n";
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  std::vector<std::string> collect(const std::string& config, const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> argv = {test::bin("ips"), "collect", "--config", (dir_ / config).string(),
                                     "--marker",       "0",       "--out",    (dir_ / "pairs.csv").string(),
                                     "--frames",       "3"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
  }
  void place(int index) const { test::write_atomically(dir_ / "placement.txt", std::to_string(index)); }
  // The true camera coordinates of the centre of the marker at place i.
  Eigen::Vector3d truth(int i) const {
    const auto scene = sim::Scene::load(dir_ / "scene.yaml");
    return scene.cameras[scene.camera_index("red")].world_to_camera({kPlaces[i][0], kPlaces[i][1], kPlaces[i][2]});
  }
  fs::path dir_;
};

TEST_F(CollectCli, TypingErrorsAreAskedAgainAndUndoRemovesAPlacement) {
  place(0);
  test::CollectSession s(collect("scene.ipsd.yaml"), dir_ / "log.txt");
  ASSERT_TRUE(s.wait_prompt(1)) << s.output();
  int prompt = 1;
  auto type = [&](const std::string& line) {
    s.type(line);
    ASSERT_TRUE(s.wait_prompt(++prompt)) << "after '" << line << "':\n" << s.output();
  };
  for (const char* bad : {"1,2", "abc", "1 2", "2.3 1.0 9", "nan 1 0", "d 1 2 0", "", "u", "s", "?"}) type(bad);
  type("2.30 1.00 0.00");
  type("u");
  place(1);
  type("2.00 1.30 0.10");
  const auto status = s.finish();
  ASSERT_TRUE(status.has_value()) << s.output();
  EXPECT_EQ(*status, 0) << s.output();
  const std::string out = s.output();
  for (const char* expected :
       {"use spaces between the numbers, not commas", "'abc' is neither a position nor a command",
        "expected 3 numbers, got 2", "z (height) 9 m is out of range", "'nan' is not a number",
        "distances need the reference points", "type the marker's position", "nothing to undo", "nothing to skip",
        "recorded placement 1 at x 2.300  y 1.000  z 0.000 m; pairs red 1",
        "undone: the placement at x 2.300  y 1.000  z 0.000 m (red); pairs red 0",
        "recorded placement 1 at x 2.000  y 1.300  z 0.100 m", "red        seen in  3/3  frames"})
    EXPECT_NE(out.find(expected), std::string::npos) << expected << "\n" << out;
  const CalibData data = load_calib_csv(dir_ / "pairs.csv");
  ASSERT_EQ(data.cameras.size(), 1u);
  ASSERT_EQ(data.cameras[0].cam.size(), 1u);
  EXPECT_EQ(data.cameras[0].world[0], Eigen::Vector3d(2.0, 1.3, 0.1));
  // What the daemon would see: the marker centre's camera coordinates by the depth formula.
  const Eigen::Vector3d d = data.cameras[0].cam[0] - truth(1);
  EXPECT_LT(d.head<2>().norm(), 0.01) << d.transpose();
  EXPECT_LT(std::abs(d.z()), 0.03) << d.transpose();
}

TEST_F(CollectCli, ResumesRefusesWhatItCannotSeeAndTakesTapeDistances) {
  // A file from an earlier session: one placement seen by red.
  std::ofstream(dir_ / "pairs.csv") << "camera,xc,yc,zc,xw,yw,zw\nred,0.01,-0.07,2.1,2.3,1,0\n";
  place(-1);  // the marker is not on the floor
  test::CollectSession s(collect("scene.ipsd.yaml", {"--ref-a", "0", "0", "--ref-b", "4.88", "0"}), dir_ / "log.txt");
  ASSERT_TRUE(s.wait_prompt(1)) << s.output();
  EXPECT_NE(s.output().find("(resumed: 1 placement(s); pairs red 1)"), std::string::npos) << s.output();
  s.type("2.3 1.0 0");
  ASSERT_TRUE(s.wait_prompt(2)) << s.output();
  EXPECT_NE(s.output().find("REFUSED: no camera saw marker 0 steadily"), std::string::npos) << s.output();
  // Place 2 by tape: the floor distances from A (0, 0) and B (4.88, 0); the point lies on the
  // left of A->B (y > 0), which nobody can tell yet (red has 1 pair): refused, then typed.
  place(2);
  const double da = std::hypot(kPlaces[2][0], kPlaces[2][1]);
  const double db = std::hypot(4.88 - kPlaces[2][0], kPlaces[2][1]);
  const std::string d = "d " + std::to_string(da) + " " + std::to_string(db) + " 0.05";
  s.type(d);
  ASSERT_TRUE(s.wait_prompt(3)) << s.output();
  EXPECT_NE(s.output().find("no camera has 4 pairs yet to tell which: add left or right"), std::string::npos)
      << s.output();
  s.type(d + " left");
  ASSERT_TRUE(s.wait_prompt(4)) << s.output();
  EXPECT_NE(s.output().find("from the distances: x 2.800  y 0.700  z 0.050 m (left, as typed)"), std::string::npos)
      << s.output();
  EXPECT_NE(s.output().find("recorded placement 2"), std::string::npos) << s.output();
  s.type("u");
  ASSERT_TRUE(s.wait_prompt(5)) << s.output();
  s.type("u");  // the placement of the earlier session
  ASSERT_TRUE(s.wait_prompt(6)) << s.output();
  s.type("q");
  const auto status = s.finish();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(*status, 0) << s.output();
  EXPECT_EQ(test::read_file(dir_ / "pairs.csv"), "camera,xc,yc,zc,xw,yw,zw\n");
}

TEST_F(CollectCli, WalksThroughAListOfPositions) {
  std::ofstream(dir_ / "list.csv") << "xw,yw,zw\n"
                                   << kPlaces[0][0] << "," << kPlaces[0][1] << "," << kPlaces[0][2] << "\n"
                                   << kPlaces[1][0] << "," << kPlaces[1][1] << "," << kPlaces[1][2] << "\n"
                                   << kPlaces[2][0] << "," << kPlaces[2][1] << "," << kPlaces[2][2] << "\n";
  place(0);
  test::CollectSession s(collect("scene.ipsd.yaml", {"--points", (dir_ / "list.csv").string()}), dir_ / "log.txt");
  ASSERT_TRUE(s.wait_prompt(1)) << s.output();
  EXPECT_NE(s.output().find("put the marker at x 2.300  y 1.000  z 0.000 m (listed 1/3)"), std::string::npos)
      << s.output();
  s.type("");
  ASSERT_TRUE(s.wait_prompt(2)) << s.output();
  s.type("s");  // skip the second
  ASSERT_TRUE(s.wait_prompt(3)) << s.output();
  place(2);
  s.type("2.81 0.70 0.05");        // as measured, a centimetre off the list
  const auto status = s.finish();  // the list is done: it ends by itself
  ASSERT_TRUE(status.has_value()) << s.output();
  EXPECT_EQ(*status, 0) << s.output();
  EXPECT_NE(s.output().find("every listed position is done or skipped"), std::string::npos) << s.output();
  const CalibData data = load_calib_csv(dir_ / "pairs.csv");
  ASSERT_EQ(data.cameras.size(), 1u);
  ASSERT_EQ(data.cameras[0].world.size(), 2u);
  EXPECT_EQ(data.cameras[0].world[0], Eigen::Vector3d(2.3, 1.0, 0.0));
  EXPECT_EQ(data.cameras[0].world[1], Eigen::Vector3d(2.81, 0.7, 0.05));
  EXPECT_LT((data.cameras[0].cam[1] - truth(2)).head<2>().norm(), 0.01);
}

// The same on a file source (a directory of images, as the daemon reads it): frames of the
// marker at place 1 rendered by `ips sim render`, the red camera's intrinsics from the config.
TEST_F(CollectCli, WorksOnAFileSource) {
  place(1);
  ASSERT_EQ(test::run({test::bin("ips"), "sim", "render", "--scene", (dir_ / "scene.yaml").string(), "--camera", "red",
                       "--frames", "2", "--out", (dir_ / "frames").string()},
                      dir_ / "render.log"),
            0)
      << test::read_file(dir_ / "render.log");
  std::ofstream(dir_ / "file.ipsd.yaml") << "cameras:\n  - {name: red, source: file, path: frames, fps: 10, "
                                            "intrinsics: "
                                         << IPS_TEST_DATA_DIR << "/ou2023/intrinsics_red.yaml}\nmodel_file: m.json\n";
  test::CollectSession s(collect("file.ipsd.yaml"), dir_ / "log.txt");
  ASSERT_TRUE(s.wait_prompt(1)) << s.output();
  s.type("2.0 1.3 0.1");
  ASSERT_TRUE(s.wait_prompt(2)) << s.output();
  const auto status = s.finish();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(*status, 0) << s.output();
  const CalibData data = load_calib_csv(dir_ / "pairs.csv");
  ASSERT_EQ(data.cameras.size(), 1u) << s.output();
  EXPECT_LT((data.cameras[0].cam[0] - truth(1)).head<2>().norm(), 0.01) << s.output();
}

TEST_F(CollectCli, RefusesAMarkerThatMoves) {
  test::CollectSession s(collect("moving.ipsd.yaml"), dir_ / "log.txt");
  ASSERT_TRUE(s.wait_prompt(1)) << s.output();
  s.type("2.3 1.0 0");
  ASSERT_TRUE(s.wait_prompt(2)) << s.output();
  const auto status = s.finish();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(*status, 0);
  EXPECT_NE(s.output().find("-> MOVED (spread > 10.0 mm)"), std::string::npos) << s.output();
  EXPECT_NE(s.output().find("REFUSED: the marker moved"), std::string::npos) << s.output();
  EXPECT_FALSE(fs::exists(dir_ / "pairs.csv"));
}

TEST_F(CollectCli, BadOptionsExitTwoAndWriteNothing) {
  const fs::path log = dir_ / "bad.log";
  struct Case {
    std::vector<std::string> argv;
    const char* expect;
  } cases[] = {
      {{test::bin("ips"), "collect", "--config", (dir_ / "none.yaml").string(), "--marker", "0", "--out",
        (dir_ / "pairs.csv").string()},
       "none.yaml"},
      {{test::bin("ips"), "collect", "--config", (dir_ / "scene.ipsd.yaml").string(), "--marker", "100", "--out",
        (dir_ / "pairs.csv").string()},
       "not in DICT_4X4_100"},
      {collect("scene.ipsd.yaml", {"--camera", "blue"}), "--camera blue"},
      {collect("scene.ipsd.yaml", {"--frames", "0"}), "--frames"},
      {collect("scene.ipsd.yaml", {"--ref-a", "0", "0"}), "--ref-b"},
      {collect("scene.ipsd.yaml", {"--points", (dir_ / "none.csv").string()}), "none.csv"},
      {{test::bin("ips"), "collect", "--config", (dir_ / "scene.ipsd.yaml").string(), "--marker", "0", "--out",
        (dir_ / "no/such/dir/pairs.csv").string()},
       "no such directory"},
  };
  for (const auto& c : cases) {
    fs::remove(log);
    EXPECT_EQ(test::run(c.argv, log), 2) << c.expect << "\n" << test::read_file(log);
    EXPECT_NE(test::read_file(log).find(c.expect), std::string::npos) << test::read_file(log);
    EXPECT_FALSE(fs::exists(dir_ / "pairs.csv"));
  }
}

}  // namespace
}  // namespace ips
