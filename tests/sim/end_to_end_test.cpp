// The published calibration procedure end to end in simulation: `ips sim collect` on the
// published layout (40 points per camera, 5 mm tape noise) -> `ips fit` -> scored on 20
// fresh points per camera with exact world positions.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include "command.h"
#include "release_only.h"

namespace fs = std::filesystem;

namespace {

const std::string kScene = (fs::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml").string();

std::pair<int, std::string> run(const std::string& args) {
  const auto r = ips::test::run_program("ips", args);
  return {r.status, r.out};
}

TEST(EndToEnd, SimCollectFitEvalMeetsThePublishedAccuracy) {
  IPS_RELEASE_ONLY("Cli.Sim* and the mapping tests (each step on its own)");
  const fs::path dir = fs::temp_directory_path() / "ips_end_to_end_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string train = (dir / "train.csv").string();
  const std::string test = (dir / "test.csv").string();
  auto r = run("sim collect --scene " + kScene + " --points 40 --tape-noise 0.005 --seed 1 --out " + train);
  ASSERT_EQ(r.first, 0) << r.second;
  r = run("sim collect --scene " + kScene + " --points 20 --tape-noise 0 --seed 2 --out " + test);
  ASSERT_EQ(r.first, 0) << r.second;

  for (const auto& [method, limit2d] : {std::pair{std::string("pr"), 0.015}, std::pair{std::string("plane"), 0.010}}) {
    SCOPED_TRACE(method);
    const std::string model = (dir / (method + ".json")).string();
    r = run("fit --data " + train + " --method " + method + " --out " + model);
    ASSERT_EQ(r.first, 0) << r.second;
    r = run("eval --model " + model + " --data " + test + " --json");
    ASSERT_EQ(r.first, 0) << r.second;
    const auto j = nlohmann::json::parse(r.second);
    ASSERT_EQ(j["cameras"].size(), 3u) << r.second;
    for (const auto& [name, stats] : j["cameras"].items()) {
      EXPECT_EQ(stats["n"], 20) << name;
      const double mean2d = stats["err2d"]["mean"].get<double>();
      EXPECT_LT(mean2d, limit2d) << name;
      std::printf("%s %s: mean 2D error %.2f cm, 3D %.2f cm\n", method.c_str(), name.c_str(), 100 * mean2d,
                  100 * stats["err3d"]["mean"].get<double>());
    }
  }
}

}  // namespace
