// The `ips locate` and `ips sim` commands, run as a user would.
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "command.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"

namespace fs = std::filesystem;

namespace {

const fs::path kData = IPS_TEST_DATA_DIR;

using CmdResult = ips::test::CommandResult;
CmdResult run(const std::string& args) { return ips::test::run_program("ips", args); }

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("ips_cli_test_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string scene_text() {
  return "render: {noise_sigma: 2, jpeg_quality: 90}\n"
         "cameras:\n  - name: red\n    intrinsics: " +
         (kData / "ou2023/intrinsics_red.yaml").string() +
         "\n    position: [2.34, 0.92, 2.13]\n"
         "markers:\n  - {id: 5, length: 0.2, x: 2.0, y: 1.2, height: 0.05, yaw_deg: 20}\n"
         "  - {id: 9, length: 0.15, x: 3.0, y: 0.5, height: 0.1, yaw_deg: -60}\n";
}

TEST(Cli, SimRenderThenLocateAgreesWithTruth) {
  const fs::path dir = temp_dir("render");
  const fs::path scene = dir / "scene.yaml";
  std::ofstream(scene) << scene_text();
  const CmdResult r = run("sim render --scene " + scene.string() + " --out " + (dir / "out").string() + " --frames 2");
  ASSERT_EQ(r.status, 0) << r.out;
  ASSERT_TRUE(fs::exists(dir / "out/red_000001.jpg"));
  std::ifstream in(dir / "out/truth_000000.json");
  const auto truth = nlohmann::json::parse(in);
  ASSERT_EQ(truth["markers"].size(), 2u);
  const auto& m5 = truth["markers"][0];
  EXPECT_EQ(m5["id"], 5);
  EXPECT_DOUBLE_EQ(m5["world"]["x"].get<double>(), 2.0);
  EXPECT_NEAR(m5["world"]["yaw"].get<double>(), 20 * M_PI / 180, 1e-12);
  // The JSON truth is the renderer's exact truth.
  const auto loaded = ips::sim::Scene::load(scene);
  const ips::sim::CameraRenderer renderer(loaded, 0);
  const auto exact = renderer.truth(0.0);
  EXPECT_DOUBLE_EQ(m5["cameras"]["red"]["corners"][2][0].get<double>(), exact[0].corners_px[2].x);
  EXPECT_DOUBLE_EQ(m5["cameras"]["red"]["zc"].get<double>(), exact[0].formula.p_cam.z());

  const CmdResult loc = run("locate --image " + (dir / "out/red_000000.jpg").string() + " --intrinsics " +
                            (kData / "ou2023/intrinsics_red.yaml").string() + " --marker-size 9=0.15 --json");
  ASSERT_EQ(loc.status, 0) << loc.out;
  const auto found = nlohmann::json::parse(loc.out)["markers"];
  ASSERT_EQ(found.size(), 2u);
  for (const auto& f : found) {
    const auto& t = f["id"] == 5 ? truth["markers"][0]["cameras"]["red"] : truth["markers"][1]["cameras"]["red"];
    EXPECT_NEAR(f["xc"].get<double>(), t["xc"].get<double>(), 0.01);
    EXPECT_NEAR(f["yc"].get<double>(), t["yc"].get<double>(), 0.01);
    EXPECT_NEAR(f["zc"].get<double>(), t["zc"].get<double>(), 0.02);
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(f["corners"][i][0].get<double>(), t["corners"][i][0].get<double>(), 0.3);
      EXPECT_NEAR(f["corners"][i][1].get<double>(), t["corners"][i][1].get<double>(), 0.3);
    }
  }
  const CmdResult text = run("locate --image " + (dir / "out/red_000000.jpg").string() + " --intrinsics " +
                             (kData / "ou2023/intrinsics_red.yaml").string());
  EXPECT_EQ(text.status, 0);
  EXPECT_NE(text.out.find("2 marker(s)"), std::string::npos) << text.out;
}

// `ips locate --config ipsd.yaml` sees what the daemon sees: its marker sizes, dictionary and
// detection settings.
TEST(Cli, LocateWithTheDaemonsConfigUsesItsMarkersAndDetectionSettings) {
  const fs::path dir = temp_dir("locate_config");
  std::ofstream(dir / "scene.yaml") << scene_text();
  ASSERT_EQ(run("sim render --scene " + (dir / "scene.yaml").string() + " --out " + (dir / "f").string()).status, 0);
  std::ofstream(dir / "model.json") << "{}";
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  auto config = [&](const std::string& detection) {
    return "cameras:\n  - {name: red, source: v4l2, device: /dev/video0, intrinsics: " + intr +
           "}\nmodel_file: model.json\nmarkers: {edge_length: 0.2, ids: {9: {edge_length: 0.15}}}\n" + detection;
  };
  std::ofstream(dir / "ipsd.yaml") << config("detection: {threshold_windows: [9, 19], refinement: edges}\n");
  std::ofstream(dir / "strict.yaml") << config("detection: {min_perimeter_px: 2000}\n");  // larger than both
  const std::string image = (dir / "f/red_000000.jpg").string();
  const auto truth = ips::sim::CameraRenderer(ips::sim::Scene::load(dir / "scene.yaml"), 0).truth(0.0);

  const CmdResult r = run("locate --image " + image + " --intrinsics " + intr + " --config " +
                          (dir / "ipsd.yaml").string() + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto found = nlohmann::json::parse(r.out)["markers"];
  ASSERT_EQ(found.size(), 2u) << r.out;
  for (const auto& f : found) {
    const auto& t = f["id"] == 5 ? truth[0] : truth[1];
    EXPECT_NEAR(f["zc"].get<double>(), t.formula.p_cam.z(), 0.02);  // 9 at 0.15 m, from markers.ids
    EXPECT_DOUBLE_EQ(f["length"].get<double>(), f["id"] == 5 ? 0.2 : 0.15);
  }
  const CmdResult none = run("locate --image " + image + " --intrinsics " + intr + " --config " +
                             (dir / "strict.yaml").string() + " --json");
  ASSERT_EQ(none.status, 0) << none.out;
  EXPECT_EQ(nlohmann::json::parse(none.out)["markers"].size(), 0u) << none.out;

  const CmdResult both = run("locate --image " + image + " --intrinsics " + intr + " --config " +
                             (dir / "ipsd.yaml").string() + " --dictionary DICT_4X4_50");
  EXPECT_NE(both.status, 0);
  EXPECT_NE(both.out.find("excludes"), std::string::npos) << both.out;
  std::ofstream(dir / "typo.yaml") << config("detection: {refinment: edges}\n");
  const CmdResult typo =
      run("locate --image " + image + " --intrinsics " + intr + " --config " + (dir / "typo.yaml").string());
  EXPECT_EQ(typo.status, 2);
  EXPECT_NE(typo.out.find("typo.yaml:5:13: detection.refinment: unknown key"), std::string::npos) << typo.out;
}

TEST(Cli, LocateRefusesBadImagesAndIntrinsics) {
  const fs::path dir = temp_dir("locate_errors");
  const std::string intr = (kData / "ou2023/intrinsics_red.yaml").string();
  std::ofstream(dir / "text.jpg") << "not an image";
  // A truncated JPEG: the first half of a real frame.
  const fs::path scene = dir / "scene.yaml";
  std::ofstream(scene) << scene_text();
  ASSERT_EQ(run("sim render --scene " + scene.string() + " --out " + (dir / "f").string()).status, 0);
  std::ifstream full(dir / "f/red_000000.jpg", std::ios::binary);
  std::ostringstream whole;
  whole << full.rdbuf();
  const std::string bytes = whole.str();
  std::ofstream(dir / "half.jpg", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(dir / "bad_intr.yaml")
      << "model: fisheye\nimage_width: 1920\nimage_height: 1080\nK: [1, 2]\nD: [0, 0, 0, 0]\n";

  for (const auto& [args, expect] : std::vector<std::pair<std::string, std::string>>{
           {"--image " + (dir / "text.jpg").string() + " --intrinsics " + intr, "text.jpg"},
           {"--image " + (dir / "half.jpg").string() + " --intrinsics " + intr, "half.jpg"},
           {"--image " + (dir / "missing.jpg").string() + " --intrinsics " + intr, "missing.jpg"},
           {"--image " + (dir / "f/red_000000.jpg").string() + " --intrinsics " + (dir / "bad_intr.yaml").string(),
            "'K'"},
           {"--image " + (dir / "f/red_000000.jpg").string() + " --intrinsics " + intr + " --dictionary DICT_3X3",
            "DICT_3X3"},
           {"--image " + (dir / "f/red_000000.jpg").string() + " --intrinsics " + intr + " --marker-size 5:0.2",
            "5:0.2"},
       }) {
    const CmdResult r = run("locate " + args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(expect), std::string::npos) << r.out;
  }
}

TEST(Cli, SimCommandsRefuseBadScenesWithoutWritingOutput) {
  const fs::path dir = temp_dir("sim_errors");
  std::ofstream(dir / "bad.yaml") << "cameras:\n  - name: red\n    intrinsics: nope.yaml\n    position: [1, 1, 2]\n";
  CmdResult r = run("sim render --scene " + (dir / "bad.yaml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("cameras[0].intrinsics"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "out"));
  r = run("sim collect --scene " + (dir / "bad.yaml").string() + " --points 3 --out " + (dir / "p.csv").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_FALSE(fs::exists(dir / "p.csv"));
  r = run("sim render --scene " + (dir / "missing.yaml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("missing.yaml"), std::string::npos) << r.out;
}

TEST(Cli, SimCollectWritesPairsConsistentWithTheCameraPose) {
  const fs::path dir = temp_dir("collect");
  const fs::path scene = dir / "scene.yaml";
  std::ofstream(scene) << scene_text();
  const CmdResult r =
      run("sim collect --scene " + scene.string() + " --points 5 --tape-noise 0 --out " + (dir / "pairs.csv").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const auto loaded = ips::sim::Scene::load(scene);
  std::ifstream in(dir / "pairs.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "camera,xc,yc,zc,xw,yw,zw");
  int rows = 0;
  while (std::getline(in, line)) {
    ++rows;
    std::stringstream ss(line);
    std::string name, f;
    std::getline(ss, name, ',');
    EXPECT_EQ(name, "red");
    double v[6];
    for (double& x : v) {
      std::getline(ss, f, ',');
      x = std::stod(f);
    }
    // Camera coordinates from the depth formula, mapped by the true pose, land within a
    // couple of centimetres of the (noise-free) world position.
    const Eigen::Vector3d w = loaded.cameras[0].camera_to_world({v[0], v[1], v[2]});
    EXPECT_NEAR(w.x(), v[3], 0.03) << line;
    EXPECT_NEAR(w.y(), v[4], 0.03) << line;
    EXPECT_NEAR(w.z(), v[5], 0.05) << line;
    EXPECT_GE(v[5], 0.0);
    EXPECT_LE(v[5], 0.2);
  }
  EXPECT_EQ(rows, 5);
}

}  // namespace
