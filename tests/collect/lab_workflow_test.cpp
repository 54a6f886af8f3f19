// The whole "Setting up a real lab" workflow of docs/lab.md, in simulation, as one test:
//   board views -> `ips calibrate` (intrinsics) -> a daemon configuration using them ->
//   `ips collect` with a marker placed at 40 points per camera (positions typed as a user
//   would: tape-measured with 5 mm noise, some as two distances) -> `ips fit --method plane`
//   -> ipsd on a scene of static markers: mean 2-D error <= 1 cm.
// Heavy (rendering + detection of every frame): the full size runs in the release build;
// under the sanitizers a small variant checks the same chain with a looser bound.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "collect_session.h"
#include "ips/mapping/calib_data.h"
#include "ips/output/packet_codec.h"
#include "ips/sim/scene.h"
#include "process_util.h"
#include "published_scene.h"
#include "release_only.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

constexpr bool kFull = test::kTimeScale == 1.0;
constexpr int kPerCamera = kFull ? 40 : 10;  // pairs per camera
constexpr int kFrames = kFull ? 3 : 2;       // frames per placement
constexpr int kViews = kFull ? 30 : 12;      // board views per camera for `ips calibrate`
const char* const kCameras[] = {"red", "white"};

struct Placement {
  sim::MarkerPose pose;
  std::string typed;
};

TEST(LabWorkflow, CalibrateCollectFitThenIpsdIsWithinOneCentimetre) {
  IPS_RELEASE_ONLY("CollectCli.*, CalibCli.* and IpsdTest.* (each step on its own)");
  const fs::path dir = fs::temp_directory_path() / ("ips_lab_workflow_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "log.txt";

  // ---- Where the user will put the marker: random places (height 0..0.2 m, any heading),
  // each in the view of a camera that still needs pairs, a few more than needed per camera
  // (the tool refuses a place a camera sees badly, e.g. at the image edge).
  const sim::Scene layout = sim::Scene::load(fs::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml");
  // Whether a camera sees the marker's four corners well inside its image (projected through
  // the camera's pose and lens, as a user would check on the camera's live view).
  auto sees = [&](const char* name, const sim::MarkerPose& pose) {
    const sim::SceneCamera& cam = layout.cameras[layout.camera_index(name)];
    const double c = std::cos(pose.yaw) * 0.1, s = std::sin(pose.yaw) * 0.1;  // half the edge
    for (const auto& [a, b] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{1, 1}, std::pair{-1, 1}}) {
      const Eigen::Vector3d pc = cam.world_to_camera({pose.x + c * a - s * b, pose.y + s * a + c * b, pose.z});
      if (!(pc.z() > 0) || std::atan2(std::hypot(pc.x(), pc.y()), pc.z()) >= cam.model.max_theta()) return false;
      const Point2 px = cam.model.project({pc.x() / pc.z(), pc.y() / pc.z()});
      if (!(px.x > 40 && px.y > 40 && px.x < 1880 && px.y < 1040)) return false;
    }
    return true;
  };
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> tape(0.0, 0.005);
  std::vector<Placement> places;
  std::vector<int> planned(std::size(kCameras), 0);
  const int want = kPerCamera + kPerCamera / 8 + 1;
  while (*std::min_element(planned.begin(), planned.end()) < want) {
    const sim::MarkerPose pose{0.2 + 4.48 * u(rng), 0.2 + 4.48 * u(rng), 0.2 * u(rng), 2 * M_PI * u(rng)};
    bool useful = false;
    std::vector<bool> seen(std::size(kCameras));
    for (std::size_t c = 0; c < seen.size(); ++c) {
      seen[c] = sees(kCameras[c], pose);
      useful = useful || (seen[c] && planned[c] < want);
    }
    if (!useful) continue;
    for (std::size_t c = 0; c < seen.size(); ++c) planned[c] += seen[c];
    // Typed as measured with a tape (5 mm noise). Every third place after the tenth is given
    // as the floor distances to A (0, 0) and B (4.88, 0) plus the height, without the side:
    // the cameras tell it from the pairs so far.
    const double x = pose.x + tape(rng), y = pose.y + tape(rng), z = std::max(0.0, pose.z + tape(rng));
    char line[120];
    if (places.size() >= 10 && places.size() % 3 == 0)
      std::snprintf(line, sizeof line, "d %.3f %.3f %.3f", std::hypot(x, y), std::hypot(4.88 - x, y), z);
    else
      std::snprintf(line, sizeof line, "%.3f %.3f %.3f", x, y, z);
    places.push_back({pose, line});
  }

  // ---- The lab: the published cameras, the calibration marker put down by "the user" (the
  // scene's placements trajectory, moved by writing the index into placement.txt).
  std::string points;
  for (const auto& p : places) {
    char buf[120];
    std::snprintf(buf, sizeof buf, "%s[%.6f, %.6f, %.6f, %.4f]", points.empty() ? "" : ", ", p.pose.x, p.pose.y,
                  p.pose.z, p.pose.yaw * 180 / M_PI);
    points += buf;
  }
  std::ofstream(dir / "lab.yaml") << test::published_scene_with(
      "markers:\n  - {id: 0, length: 0.20, trajectory: {type: placements, control: placement.txt, points: [" + points +
      "]}}\n");

  // ---- INTRINSICS STEP: 30 board views per camera -> `ips calibrate` -> INTR.yaml.
  std::map<std::string, fs::path> intrinsics;
  for (const std::string name : kCameras) {
    const fs::path views_dir = dir / ("views_" + name), intr = dir / ("intrinsics_" + name + ".yaml");
    ASSERT_EQ(test::run({test::bin("ips"), "sim", "board-views", "--scene", (dir / "lab.yaml").string(), "--camera",
                         name, "--views", std::to_string(kViews), "--out", views_dir.string()},
                        log, std::chrono::seconds(static_cast<long>(600 * test::kTimeScale))),
              0)
        << test::read_file(log);
    ASSERT_EQ(test::run({test::bin("ips"), "calibrate", "--images", views_dir.string(), "--board",
                         "charuco:7x5:0.04:0.03:DICT_5X5_100", "--model", "fisheye", "--out", intr.string()},
                        log, std::chrono::seconds(static_cast<long>(600 * test::kTimeScale))),
              0)
        << test::read_file(log);
    intrinsics[name] = intr;
  }
  // ---- end of the INTRINSICS STEP.

  // ---- The daemon's configuration, used by `ips collect` (the model file comes later).
  auto config = [&](const std::string& scene, double fps, const std::string& rest) {
    std::string c = "cameras:\n";
    for (const std::string name : kCameras)
      c += "  - {name: " + name + ", source: synthetic, scene: " + scene + ", fps: " + std::to_string(fps) +
           ", intrinsics: " + intrinsics[name].string() + "}\n";
    return c + "model_file: model.json\n" + rest;
  };
  std::ofstream(dir / "collect.yaml") << config("lab.yaml", 20, "markers: {edge_length: 0.20}\n");

  // ---- `ips collect`: place, type, wait for the next prompt; repeat.
  {
    test::CollectSession s({test::bin("ips"), "collect", "--config", (dir / "collect.yaml").string(), "--marker", "0",
                            "--out", (dir / "pairs.csv").string(), "--frames", std::to_string(kFrames), "--ref-a", "0",
                            "0", "--ref-b", "4.88", "0"},
                           dir / "collect.log");
    ASSERT_TRUE(s.wait_prompt(1, 120)) << s.output();
    for (std::size_t k = 0; k < places.size(); ++k) {
      test::write_atomically(dir / "placement.txt", std::to_string(k));
      s.type(places[k].typed);
      ASSERT_TRUE(s.wait_prompt(static_cast<int>(k) + 2, 120)) << s.output();
    }
    const auto status = s.finish();
    ASSERT_TRUE(status.has_value()) << s.output();
    ASSERT_EQ(*status, 0) << s.output();
    const std::string out = s.output();
    EXPECT_EQ(out.find("MOVED"), std::string::npos) << out;
    EXPECT_NE(out.find("(the left side: "), std::string::npos) << "no side told by the cameras\n" << out;
    EXPECT_EQ(out.find("(the right side: "), std::string::npos) << "a wrong side\n" << out;
    int refused = 0;
    for (std::size_t at = 0; (at = out.find("REFUSED", at)) != std::string::npos; ++at) ++refused;
    std::printf("[ collect  ] %zu placements typed, %d refused\n", places.size(), refused);
  }
  const CalibData pairs = load_calib_csv(dir / "pairs.csv");
  for (const std::string name : kCameras) {
    ASSERT_NE(pairs.find(name), nullptr) << name;
    EXPECT_GE(pairs.find(name)->cam.size(), static_cast<std::size_t>(kPerCamera)) << name;
    std::printf("[ collect  ] %s: %zu pairs from %zu placements\n", name.c_str(), pairs.find(name)->cam.size(),
                places.size());
  }

  // ---- `ips fit --method plane`.
  ASSERT_EQ(test::run({test::bin("ips"), "fit", "--data", (dir / "pairs.csv").string(), "--method", "plane", "--out",
                       (dir / "model.json").string()},
                      log),
            0)
      << test::read_file(log);

  // ---- ipsd on the same cameras watching static markers of known heights.
  const double heights[] = {0.0, 0.05, 0.10, 0.15, 0.12, 0.08};
  const double xy[][2] = {{1.6, 0.8}, {3.0, 1.2}, {2.4, 1.6}, {1.8, 2.6}, {3.1, 2.9}, {2.2, 0.4}};
  std::string markers = "markers:\n", ids = "markers:\n  edge_length: 0.20\n  ids:\n";
  for (int i = 0; i < 6; ++i) {
    markers += "  - {id: " + std::to_string(i + 1) + ", length: 0.20, x: " + std::to_string(xy[i][0]) +
               ", y: " + std::to_string(xy[i][1]) + ", height: " + std::to_string(heights[i]) +
               ", yaw_deg: " + std::to_string(40 * i) + "}\n";
    ids += "    " + std::to_string(i + 1) + ": {height: " + std::to_string(heights[i]) + "}\n";
  }
  std::ofstream(dir / "run.yaml") << test::published_scene_with(markers);
  test::UdpReceiver rx;
  std::ofstream(dir / "ipsd.yaml") << config("run.yaml", 4,
                                             ids + "outputs:\n  - {type: unicast, address: 127.0.0.1, port: " +
                                                 std::to_string(rx.port) + ", format: binary}\n");
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", (dir / "ipsd.yaml").string()}, dir / "ipsd.log");
  const test::ChildGuard guard(pid);
  const sim::Scene run_scene = sim::Scene::load(dir / "run.yaml");
  double sum = 0.0, worst = 0.0;
  int n = 0, datagrams = 0;
  std::map<int, int> per_marker;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(40 * test::kTimeScale);
  while (std::chrono::steady_clock::now() < end && datagrams < 16) {
    const auto bytes = rx.receive(200);
    if (!bytes) continue;
    ++datagrams;
    for (const auto& m : decode_datagram(*bytes).markers) {
      const sim::MarkerPose truth = run_scene.marker_pose(static_cast<int>(m.id), 0.0);
      const double e = std::hypot(m.x - truth.x, m.y - truth.y);
      sum += e;
      worst = std::max(worst, e);
      ++n;
      ++per_marker[static_cast<int>(m.id)];
    }
  }
  ASSERT_GT(n, 0) << test::read_file(dir / "ipsd.log");
  EXPECT_EQ(per_marker.size(), 6u) << "not every static marker was reported";
  const double mean = sum / n;
  std::printf("[ ipsd     ] %d positions of %zu markers in %d datagrams: mean 2D error %.2f cm, max %.2f cm\n", n,
              per_marker.size(), datagrams, mean * 100, worst * 100);
  EXPECT_LE(mean, kFull ? 0.01 : 0.02);
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace ips
