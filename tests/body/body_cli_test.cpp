// The programs on bodies: `ips sim render` writes the body truth; `ipsd --check` refuses a bad
// body definition with exit 2 naming the key.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include "command.h"

namespace {

namespace fs = std::filesystem;

ips::test::CommandResult run(const std::string& program, const std::string& args) {
  return ips::test::run_program(program, args);
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("ips_body_cli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(BodyCli, SimRenderWritesBodyTruth) {
  const fs::path dir = temp_dir("render");
  const auto r = run("ips", "sim render --scene " + std::string(IPS_CONFIG_DIR) + "/scenes/bodies_lab.yaml --out " +
                                dir.string() + " --frames 2 --fps 2 --camera red");
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(dir / "truth_000001.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j["bodies"].size(), 2u);
  EXPECT_EQ(j["bodies"][0]["name"], "turtle");
  // At t = 0.5 s on the 1.95 m circle at 0.5 m/s: angle 0.5 * 0.5 / 1.95 rad from +x, heading
  // 90 deg more (counter-clockwise).
  const double a = 0.25 / 1.95;
  EXPECT_NEAR(j["bodies"][0]["x"].get<double>(), 2.44 + 1.95 * std::cos(a), 1e-9);
  EXPECT_NEAR(j["bodies"][0]["y"].get<double>(), 2.44 + 1.95 * std::sin(a), 1e-9);
  EXPECT_NEAR(j["bodies"][0]["yaw"].get<double>(), a + M_PI / 2, 1e-9);
  EXPECT_NEAR(j["bodies"][0]["q"][0].get<double>(), std::cos((a + M_PI / 2) / 2), 1e-9);  // w
  EXPECT_NEAR(j["bodies"][0]["q"][3].get<double>(), std::sin((a + M_PI / 2) / 2), 1e-9);  // z
  ASSERT_EQ(j["markers"].size(), 7u);  // five cube faces, two flat markers
  EXPECT_EQ(j["markers"][0]["body"], "turtle");
  EXPECT_EQ(j["markers"][6]["body"], "long");
  fs::remove_all(dir);
}

TEST(BodyCli, IpsdCheckRefusesBadBodies) {
  const fs::path dir = temp_dir("check");
  std::ofstream(dir / "model.json") << "{}";
  const std::string head = "cameras:\n  - {name: red, source: synthetic, scene: " + std::string(IPS_CONFIG_DIR) +
                           "/scenes/bodies_lab.yaml}\nmodel_file: model.json\n";
  const std::pair<std::string, std::string> cases[] = {
      {"bodies:\n  - {name: a, cube: {id: 1, edge: 0.05, size: 0}}\n", "bodies[0].cube.size: must be > 0"},
      {"bodies:\n  - {name: a, cube: {id: 1, edge: 0.05, size: 0.1}}\n  - {name: b, flat: [{id: 1, edge: 0.1, offset: "
       "[0, 0]}]}\n",
       "bodies[1]: marker id 1 is already used by body 'a'"},
      {"bodies:\n  - {name: a, flat: [{id: 2, edge: 0.1, offset: [0, 0]}, {id: 3, edge: 0.1, offset: [0.05, 0]}]}\n",
       "bodies[0].flat[1]: overlapping faces in one plane"},
  };
  for (const auto& [bodies, want] : cases) {
    std::ofstream(dir / "ipsd.yaml") << head << bodies;
    const auto r = run("ipsd", "--check --config " + (dir / "ipsd.yaml").string());
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find("ipsd.yaml:"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(want), std::string::npos) << r.out;
  }
  fs::remove_all(dir);
}

}  // namespace
