// The `ips fit / eval / cv / compare` commands, run as the built binary.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "command.h"
#include "test_util.h"

namespace {

namespace fs = std::filesystem;

using CommandResult = ips::test::CommandResult;
CommandResult run(const std::string& args) { return ips::test::run_program("ips", args); }  // stderr merged

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ips_cli_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void write(const std::string& name, const std::string& text) const { std::ofstream(dir_ / name) << text; }
  fs::path dir_;
};

// Training pairs that are an exact translation by (1, 2, 0): `rt` recovers it exactly.
const char* kTrain =
    "camera,xc,yc,zc,xw,yw,zw\n"
    "a,0,0,2,1,2,2\n"
    "a,1,0,2,2,2,2\n"
    "a,0,1,2,1,3,2\n"
    "a,1,1,2.1,2,3,2.1\n"
    "a,0.5,0.2,1.9,1.5,2.2,1.9\n";
// Test pairs whose world points are off by (0.03, 0.04, 0), (0, 0, 0.02), (0.06, 0.08, 0):
// 3D errors 0.05, 0.02, 0.10 (mean 0.0566667, std 0.0404145); 2D 0.05, 0, 0.10 (mean 0.05,
// std 0.05) — see error_stats_test.cpp for the arithmetic.
const char* kTest =
    "camera,xc,yc,zc,xw,yw,zw\n"
    "a,0,0,2,1.03,2.04,2\n"
    "a,1,1,2,2,3,2.02\n"
    "a,0.5,0.5,2,1.56,2.58,2\n";

TEST_F(Cli, FitThenEvalJsonMatchesHandComputedStatistics) {
  write("train.csv", kTrain);
  write("test.csv", kTest);
  CommandResult r = run("fit --data " + path("train.csv") + " --method rt --out " + path("m.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("eval --model " + path("m.json") + " --data " + path("test.csv") + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.size(), 1u);
  const auto& a = j["cameras"]["a"];
  EXPECT_EQ(a["n"], 3);
  EXPECT_NEAR(a["err3d"]["mean"].get<double>(), 0.17 / 3.0, 1e-9);
  EXPECT_NEAR(a["err3d"]["min"].get<double>(), 0.02, 1e-9);
  EXPECT_NEAR(a["err3d"]["max"].get<double>(), 0.10, 1e-9);
  EXPECT_NEAR(a["err3d"]["std"].get<double>(), 0.0404145188432738, 1e-9);
  EXPECT_NEAR(a["err2d"]["mean"].get<double>(), 0.05, 1e-9);
  EXPECT_NEAR(a["err2d"]["min"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(a["err2d"]["max"].get<double>(), 0.10, 1e-9);
  EXPECT_NEAR(a["err2d"]["std"].get<double>(), 0.05, 1e-9);
  // Human output: cm.
  r = run("eval --model " + path("m.json") + " --data " + path("test.csv"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("5.667"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("4.041"), std::string::npos) << r.out;
}

// Exact rigid data: every left-out pair is predicted exactly.
TEST_F(Cli, CvJsonOnExactDataAndSizes) {
  write("train.csv", kTrain);
  CommandResult r = run("cv --data " + path("train.csv") + " --method rt --loo --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["cameras"]["a"]["n"], 5);
  EXPECT_LT(j["cameras"]["a"]["err3d"]["max"].get<double>(), 1e-9);
  r = run("cv --data " + path("train.csv") + " --method rt --folds 1");
  EXPECT_EQ(r.status, 2) << r.out;
  r = run("cv --data " + path("train.csv") + " --method pr --loo");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("camera 'a' (5 pairs): method 'pr' needs at least 10"), std::string::npos) << r.out;
}

TEST_F(Cli, BadCsvExitsTwoNamesThePlaceAndWritesNothing) {
  write("bad.csv", "camera,xc,yc,zc,xw,yw,zw\na,0,0,2,1,2,2\na,1,0,2,2,NaN,2\n");
  CommandResult r = run("fit --data " + path("bad.csv") + " --method rt --out " + path("m.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("bad.csv:3: column 'yw' (6): 'NaN' is not a finite number"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(path("m.json")));
  // Too few rows for the method: named, and nothing written.
  write("train.csv", kTrain);
  r = run("fit --data " + path("train.csv") + " --method pr --out " + path("m.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("camera 'a' has 5 pairs; method 'pr' needs at least 10"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(path("m.json")));
  r = run("fit --data " + path("train.csv") + " --method nope --out " + path("m.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("unknown mapping method 'nope'"), std::string::npos) << r.out;
  r = run("fit --data " + path("train.csv") + " --method rt --camera zz --out " + path("m.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("no pairs for camera 'zz' (the file has: a)"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(path("m.json")));
}

TEST_F(Cli, BadModelFileExitsTwo) {
  write("m.json", "{\"format\":\"ipsd-model\",\"version\":7,\"cameras\":{\"a\":{}}}");
  write("test.csv", kTest);
  CommandResult r = run("eval --model " + path("m.json") + " --data " + path("test.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("version 7 is not supported"), std::string::npos) << r.out;
}

TEST_F(Cli, FitSelectedCamerasOfThePublishedDataAndEvalRefusesMissingOnes) {
  CommandResult r = run("fit --data " + ips::test::train40_path() + " --method pr --camera red --camera black --out " +
                        path("m.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto model = nlohmann::json::parse(std::ifstream(path("m.json")));
  EXPECT_EQ(model["format"], "ipsd-model");
  EXPECT_EQ(model["version"], 1);
  EXPECT_EQ(model["cameras"].size(), 2u);
  EXPECT_EQ(model["cameras"]["red"]["method"], "pr");
  EXPECT_EQ(model["cameras"]["red"]["training"]["n"], 40);
  r = run("eval --model " + path("m.json") + " --data " + ips::test::train40_path());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("camera 'white' is not in"), std::string::npos) << r.out;
}

TEST_F(Cli, CompareListsEveryMethodPerCamera) {
  // The first 20 pairs of the red camera of the published data (keeps the ASan run short).
  std::ifstream in(ips::test::train40_path());
  std::string line, text;
  std::map<std::string, int> count;
  std::getline(in, line);
  text = line + "\n";
  while (std::getline(in, line))
    if (line.rfind("red,", 0) == 0 && ++count["red"] <= 20) text += line + "\n";
  write("train20.csv", text);
  CommandResult r = run("compare --train " + path("train20.csv") + " --test " + path("train20.csv") + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["cameras"].size(), 1u);
  for (const char* cam : {"red"}) {
    EXPECT_EQ(j["cameras"][cam]["pr"]["n"], 20) << cam;
    const auto& c = j["cameras"][cam];
    EXPECT_EQ(c.size(), 10u) << cam;  // every method but auto
    // Scored on its own training data, ki interpolates: (numerically) zero error.
    EXPECT_LT(c["ki"]["err3d"]["max"].get<double>(), 1e-6) << cam;
    EXPECT_GT(c["pr"]["err3d"]["mean"].get<double>(), 1e-3) << cam;
  }
}

}  // namespace
