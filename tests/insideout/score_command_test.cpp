// `ips score` on trajectories whose errors are computed by hand: the truth interpolated at each
// estimate's time, RMSE, the detection ratio with its timeout, per id; bad input exits 2.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "command.h"
#include "ips/output/packet_codec.h"

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

// ipsd's stream as `ips listen --record` writes it: marker 1 as in the CSV above (its capture
// time the datagram's realtime + the record's dt), body "cart" scored by name, a datagram
// repeated (a second output's copy) skipped, a held heading not scored.
TEST_F(ScoreCommand, AStreamRecordedByIpsListenIsScoredPerMarkerAndBody) {
  std::ofstream(dir_ / "truth.csv") << "t_ns,id,x,y,z,yaw\n"
                                    << "0,1,0,0,0,0\n1000000000,1,1,0,0,0.2\n2000000000,1,2,0,0,0.4\n"
                                    << "0,cart,3,3,0,0\n2000000000,cart,3,3,0,0\n";
  std::ofstream jsonl(dir_ / "stream.jsonl");
  const auto datagram = [](std::int64_t t_real, std::int32_t dt_us, ips::MarkerRecord m, double cart_x) {
    ips::Datagram d;
    d.version = 2;
    d.has_sources = true;
    d.capture_realtime_ns = t_real;
    m.id = 1;
    m.dt_us = dt_us;
    d.markers.push_back(m);
    ips::BodyRecord b;
    b.name = "cart";
    b.x = cart_x;
    b.y = 3;
    b.has_yaw = false;
    d.bodies.push_back(b);
    return ips::encode_json(d);
  };
  ips::MarkerRecord a;
  a.x = 0.5, a.y = 0.003, a.yaw = 0.11;
  ips::MarkerRecord b;
  b.x = 1.504, b.z = 0.002, b.yaw = 0.3;
  ips::MarkerRecord held = b;
  held.has_yaw = false;
  held.yaw = 2.0;                                          // the last heading, held: not scored
  jsonl << datagram(400'000'000, 100'000, a, 3.006);       // marker at 0.5 s; cart at 0.4 s, 6 mm off
  jsonl << datagram(1'500'000'000, 0, b, 3.0);             // at 1.5 s
  jsonl << datagram(1'500'000'000, 0, b, 3.0);             // the same update again
  jsonl << datagram(1'800'000'000, 0, held, 3.0) << "\n";  // at 1.8 s: 1.8 m is the truth, 296 mm off
  jsonl.close();
  const auto r = ips::test::run_program(
      "ips", "score --stream " + (dir_ / "stream.jsonl").string() + " --truth " + (dir_ / "truth.csv").string());
  ASSERT_EQ(r.status, 0) << r.out;
  // id 1: errors 3, 4, 296 mm: RMSE sqrt((9 + 16 + 296^2) / 3) = 170.92 mm; yaw of the first two
  // only: sqrt(0.01^2 / 2) = 0.405 deg. cart: 6, 0, 0 mm: RMSE 3.46 mm.
  EXPECT_NE(r.out.find("2 records not after their object's previous one, skipped"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("     1         3         3     100.0%    170.92 mm"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0.405 deg"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  cart         3         3     100.0%      3.46 mm"), std::string::npos) << r.out;
  EXPECT_LT(r.out.find("     1 "), r.out.find("  cart ")) << "markers by number, then bodies by name";

  std::ofstream(dir_ / "stream.jsonl") << "{\"type\":\"ips.positions\"\n";
  const auto bad = ips::test::run_program(
      "ips", "score --stream " + (dir_ / "stream.jsonl").string() + " --truth " + (dir_ / "truth.csv").string());
  EXPECT_EQ(bad.status, 2) << bad.out;
  EXPECT_NE(bad.out.find("stream.jsonl:1: not a datagram of the stream's JSON form"), std::string::npos) << bad.out;
  const auto both = ips::test::run_program("ips", args(" --stream " + (dir_ / "stream.jsonl").string()));
  EXPECT_NE(both.status, 0) << both.out;
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
