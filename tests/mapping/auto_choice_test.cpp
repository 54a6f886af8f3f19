// `ips fit --method auto` picks what the daemon will use: `plane` competes when the marker
// heights will be known (the default, or a config that gives them) and wins on the published
// pairs and on simulated ones, where it also serves the daemon best; without known heights
// it cannot be used and is not chosen. Runs the built `ips`.
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "release_only.h"
#include "test_util.h"

namespace {

namespace fs = std::filesystem;
using ips::support::run;

class AutoChoice : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ips_auto_choice_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // Runs `ips ARGS...`; the exit status, the output in `out`.
  int ips(std::vector<std::string> args, std::string& out) const {
    args.insert(args.begin(), std::string(IPS_BINARY_DIR) + "/ips");
    const fs::path log = dir_ / "log.txt";
    fs::remove(log);
    const int status = run(args, log, std::chrono::seconds(300));
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    out = text.str();
    return status;
  }
  std::map<std::string, std::string> chosen(const fs::path& model) const {
    std::ifstream in(model);
    const auto j = nlohmann::json::parse(in);
    std::map<std::string, std::string> c;
    for (const auto& [camera, entry] : j["cameras"].items()) {
      c[camera] = entry["params"]["chosen"].get<std::string>();
      EXPECT_TRUE(entry["params"].contains("heights_known"));
    }
    return c;
  }
  fs::path dir_;
};

TEST_F(AutoChoice, PublishedPairs) {
  IPS_RELEASE_ONLY("CrossValidation.* (the folds and the choice on small data)");
  const std::string model = (dir_ / "m.json").string();
  std::string out;
  // Default: heights known -> plane competes with its true (3-D = 2-D) error and wins.
  ASSERT_EQ(ips({"fit", "--data", ips::test::train40_path(), "--method", "auto", "--folds", "5", "--out", model}, out),
            0)
      << out;
  for (const auto& [camera, method] : chosen(model)) EXPECT_EQ(method, "plane") << camera << "\n" << out;
  EXPECT_NE(out.find("marker heights known (--heights known, the default): plane competed"), std::string::npos) << out;
  EXPECT_NE(out.find("red: auto chose 'plane': least 5-fold cross-validated mean 3-D error"), std::string::npos) << out;
  // A config without any marker height: plane cannot be used, so it is not chosen.
  std::ofstream(dir_ / "noheight.yaml") << "cameras:\n  - {name: red, source: file, path: " << dir_.string()
                                        << ", intrinsics: " << IPS_TEST_DATA_DIR
                                        << "/ou2023/intrinsics_red.yaml}\nmodel_file: not_yet.json\n";
  ASSERT_EQ(ips({"fit", "--data", ips::test::train40_path(), "--method", "auto", "--folds", "5", "--camera", "red",
                 "--config", (dir_ / "noheight.yaml").string(), "--out", model},
                out),
            0)
      << out;
  EXPECT_NE(chosen(model).at("red"), "plane") << out;
  EXPECT_NE(out.find("marker heights unknown"), std::string::npos) << out;
  EXPECT_NE(out.find("gives no marker height"), std::string::npos) << out;
  EXPECT_EQ(out.find("(next: plane"), std::string::npos) << "plane in the runners-up\n" << out;
  EXPECT_EQ(out.find(", plane "), std::string::npos) << "plane in the runners-up\n" << out;
  // The same config with markers.height: known again.
  std::ofstream(dir_ / "height.yaml") << "cameras:\n  - {name: red, source: file, path: " << dir_.string()
                                      << ", intrinsics: " << IPS_TEST_DATA_DIR
                                      << "/ou2023/intrinsics_red.yaml}\nmarkers: {height: 0.1}\nmodel_file: x.json\n";
  ASSERT_EQ(ips({"fit", "--data", ips::test::train40_path(), "--method", "auto", "--folds", "5", "--camera", "red",
                 "--config", (dir_ / "height.yaml").string(), "--out", model},
                out),
            0)
      << out;
  EXPECT_EQ(chosen(model).at("red"), "plane") << out;
  // Bad values: exit 2, nothing written.
  fs::remove(model);
  EXPECT_EQ(
      ips({"fit", "--data", ips::test::train40_path(), "--method", "auto", "--heights", "maybe", "--out", model}, out),
      2)
      << out;
  EXPECT_NE(out.find("--heights"), std::string::npos) << out;
  EXPECT_EQ(ips({"fit", "--data", ips::test::train40_path(), "--method", "auto", "--heights", "known", "--config",
                 (dir_ / "height.yaml").string(), "--out", model},
                out),
            2)
      << out;
  EXPECT_FALSE(fs::exists(model));
}

// On simulated pairs (tape noise 5 mm) judged against exact positions, with the heights known
// as in the daemon: the default choice (plane) beats the choice made without heights.
TEST_F(AutoChoice, SimulatedPairsTheChoiceServesTheDaemon) {
  IPS_RELEASE_ONLY("CrossValidation.* (the choice) and IpsdTest.* (the daemon on a model file)");
  const std::string scene = std::string(IPS_CONFIG_DIR) + "/scenes/ou2023.yaml";
  const std::string train = (dir_ / "train.csv").string(), test = (dir_ / "test.csv").string();
  std::string out;
  ASSERT_EQ(
      ips({"sim", "collect", "--scene", scene, "--camera", "white", "--points", "30", "--seed", "3", "--out", train},
          out),
      0)
      << out;
  ASSERT_EQ(ips({"sim", "collect", "--scene", scene, "--camera", "white", "--points", "20", "--seed", "4",
                 "--tape-noise", "0", "--out", test},
                out),
            0)
      << out;
  double err[2];
  const char* heights[2] = {"known", "unknown"};
  for (int k = 0; k < 2; ++k) {
    const std::string model = (dir_ / (std::string(heights[k]) + ".json")).string();
    ASSERT_EQ(
        ips({"fit", "--data", train, "--method", "auto", "--folds", "5", "--heights", heights[k], "--out", model}, out),
        0)
        << out;
    const std::string method = chosen(model).at("white");
    EXPECT_EQ(method == "plane", k == 0) << method;
    ASSERT_EQ(ips({"eval", "--model", model, "--data", test, "--json"}, out), 0) << out;
    err[k] = nlohmann::json::parse(out)["cameras"]["white"]["err3d"]["mean"].get<double>();
    std::printf("[ auto     ] heights %s: chose %s, 3-D error on exact pairs %.2f cm\n", heights[k], method.c_str(),
                err[k] * 100);
  }
  EXPECT_LT(err[0], err[1]);
}

}  // namespace
