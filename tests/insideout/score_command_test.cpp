// `ips score` on trajectories whose errors are computed by hand: the truth interpolated at each
// estimate's time, RMSE, the detection ratio with its timeout, per id; bad input exits 2.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "command.h"

namespace fs = std::filesystem;

namespace {

class ScoreCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ips_score_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // Object 1 drives along x at 1 m/s, heading 0.2 rad/s; object 2 was never estimated.
    std::ofstream(dir_ / "truth.csv") << "t_ns,id,x,y,z,yaw\n"
                                      << "0,1,0,0,0,0\n1000000000,1,1,0,0,0.2\n2000000000,1,2,0,0,0.4\n"
                                      << "0,2,5,5,0,0\n";
    // Columns in another order and one more (sx): read by name. At 0.5 s the truth is
    // (0.5, 0, 0) heading 0.1: 3 mm off in y, 0.01 rad in heading; at 1.5 s (1.5, 0, 0)
    // heading 0.3: 4 mm off in x, 2 mm in z. Id 7 has no truth.
    std::ofstream(dir_ / "est.csv") << "t_ns,x,y,z,yaw,sx,id\n"
                                    << "500000000,0.5,0.003,0,0.11,0.001,1\n"
                                    << "1500000000,1.504,0,0.002,0.3,0.001,1\n"
                                    << "0,9,9,0,0,0.001,7\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string args(const std::string& extra = "") const {
    return "score --estimate " + (dir_ / "est.csv").string() + " --truth " + (dir_ / "truth.csv").string() + extra;
  }
  fs::path dir_;
};

TEST_F(ScoreCommand, ErrorsAgainstTheInterpolatedTruthAndTheDetectionRatio) {
  const auto r = ips::test::run_program("ips", args(" --plot " + (dir_ / "error.png").string()));
  ASSERT_EQ(r.status, 0) << r.out;
  // id 1: RMSE 2-D sqrt((3^2 + 4^2) / 2) = 3.54 mm, max 4, 3-D sqrt((9 + 16 + 4) / 2) = 3.81,
  // yaw sqrt(0.01^2 / 2) = 0.405 deg; every truth row has an estimate within 0.5 s.
  EXPECT_NE(
      r.out.find(
          "     1         2         2     100.0%      3.54 mm      4.00 mm      4.00 mm      3.81 mm    0.405 deg"),
      std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("     2         0         0       0.0%            -"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("id 7: 1 estimates, no truth: not scored"), std::string::npos) << r.out;
  EXPECT_GT(fs::file_size(dir_ / "error.png"), 1000u);
  // A timeout of 0.4 s: no truth row is that close to an estimate, none to a truth row either.
  const auto tight = ips::test::run_program("ips", args(" --timeout 0.4"));
  ASSERT_EQ(tight.status, 0) << tight.out;
  EXPECT_NE(tight.out.find("     1         2         0       0.0%"), std::string::npos) << tight.out;
}

TEST_F(ScoreCommand, BadInputExitsTwoNamingFileAndLine) {
  std::ofstream(dir_ / "est.csv") << "t_ns,x,y\n200,0,0\n100,0,0\n";
  auto r = ips::test::run_program("ips", args());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("est.csv:3: t_ns not after the previous row's"), std::string::npos) << r.out;
  std::ofstream(dir_ / "est.csv") << "time,x,y\n100,0,0\n";
  r = ips::test::run_program("ips", args());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("est.csv:1: no column 't_ns'"), std::string::npos) << r.out;
  std::ofstream(dir_ / "est.csv") << "t_ns,x,y\n100,nan,0\n";
  r = ips::test::run_program("ips", args());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("est.csv:2: column 'x'"), std::string::npos) << r.out;
}

}  // namespace
