// The files of `ips trilaterate`: the ranges CSV parsed against hand-written rows (fix grouping,
// inline mobile references, sigmas), every malformed input named by file:line, and the tool
// itself on ranges with exact truth.
#include "ips/ranging/ranges_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "command.h"
#include "ips/core/error.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

const AnchorMap kAnchors = {{"a", {0, 0, 0}}, {"b", {4, 0, 0}}, {"c", {0, 4, 0}}, {"7", {0, 0, 4}}};

std::string error_of(const std::string& csv) {
  std::istringstream in(csv);
  try {
    parse_ranges_csv(in, "r.csv", kAnchors);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(RangesFile, RowsAreGroupedByFixWithInlineReferencesAndSigmas) {
  std::istringstream in(
      "fix,reference,range,sigma,ref_x,ref_y,ref_z,ref_sigma\n"
      "1,a,1.5,,,,,\n"
      "2,b,2.0,0.05,,,,\n"
      "1,7,2.5,0.03,,,,0.04\n"
      "\n"
      "1,robot3,1.0,0.03,1,2,0.5,0.04\n");
  const auto fixes = parse_ranges_csv(in, "r.csv", kAnchors, 0.1);
  ASSERT_EQ(fixes.size(), 2u);
  EXPECT_EQ(fixes[0].fix, "1");
  EXPECT_EQ(fixes[0].line, 2u);
  ASSERT_EQ(fixes[0].ranges.size(), 3u);
  EXPECT_EQ(fixes[0].ranges[0].sigma_m, 0.1);                        // the default
  EXPECT_NEAR(fixes[0].ranges[1].sigma_m, 0.05, 1e-12);              // hypot(0.03, 0.04)
  EXPECT_EQ(fixes[0].ranges[1].anchor, Eigen::Vector3d(0, 0, 4));    // anchor id "7"
  EXPECT_EQ(fixes[0].ranges[2].anchor, Eigen::Vector3d(1, 2, 0.5));  // inline: a mobile reference
  EXPECT_EQ(fixes[1].fix, "2");
  EXPECT_EQ(fixes[1].ranges[0].anchor, Eigen::Vector3d(4, 0, 0));
  // Which anchor each range is to ("" for an inline reference): for each anchor's bias.
  EXPECT_EQ(fixes[0].anchors, (std::vector<std::string>{"a", "7", ""}));
  EXPECT_EQ(fixes[1].anchors, (std::vector<std::string>{"b"}));
}

TEST(RangesFile, PositionsByFixWithOptionalSigmaAndOtherColumnsIgnored) {
  std::istringstream in("fix,tag,t,x,y,z,sigma\nf1,7,0.0,1,2,0.3,\nf2,7,0.2,1.5,2.5,0.3,0.01\n");
  const auto p = parse_positions_csv(in, "p.csv");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.at("f1").position, Eigen::Vector3d(1, 2, 0.3));
  EXPECT_FALSE(p.at("f1").sigma_m);
  EXPECT_EQ(p.at("f2").sigma_m, 0.01);
  const auto error = [](const std::string& csv) -> std::string {
    std::istringstream text(csv);
    try {
      parse_positions_csv(text, "p.csv");
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error(""), "p.csv: empty file (expected the header fix,x,y,z)");
  EXPECT_NE(error("fix,x,y\n").find("p.csv:1: the header has no column 'z'"), std::string::npos);
  EXPECT_NE(error("fix,x,y,z\nf1,1,2,nan\n").find("p.csv:2: column 'z': 'nan' is not a finite"), std::string::npos);
  EXPECT_NE(error("fix,x,y,z\nf1,1,2,3\nf1,1,2,3\n").find("p.csv:3: fix 'f1' is given twice"), std::string::npos);
  EXPECT_NE(error("fix,x,y,z,sigma\nf1,1,2,3,-1\n").find("p.csv:2: column 'sigma': negative"), std::string::npos);
  EXPECT_NE(error("fix,x,y,z\nf1,1,2\n").find("p.csv:2: 3 fields, the header has 4"), std::string::npos);
}

TEST(RangesFile, AnchorsMayGiveABias) {
  const fs::path file = fs::temp_directory_path() / ("ips_anchors_bias_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(file) << "anchors:\n  - {id: 1, x: 0, y: 0, z: 2, bias: 0.04}\n  - {id: 2, x: 4, y: 0, z: 2}\n";
  std::map<std::string, double> biases;
  const AnchorMap anchors = load_anchors_yaml(file, &biases);
  EXPECT_EQ(anchors.size(), 2u);
  EXPECT_EQ(biases.at("1"), 0.04);
  EXPECT_EQ(biases.at("2"), 0.0);
  std::ofstream(file) << "anchors:\n  - {id: 1, x: 0, y: 0, z: 2, bais: 0.04}\n";
  EXPECT_THROW(load_anchors_yaml(file), InputError);  // a typo is an error, not a bias of 0
  fs::remove(file);
}

TEST(RangesFile, MalformedRowsAreNamedByFileAndLine) {
  EXPECT_EQ(error_of(""), "r.csv: empty file (expected the header fix,reference,range)");
  EXPECT_NE(error_of("fix,reference\n").find("r.csv:1: the header has no column 'range'"), std::string::npos);
  EXPECT_NE(error_of("fix,reference,range,colour\n").find("r.csv:1: unknown column 'colour'"), std::string::npos);
  EXPECT_NE(error_of("fix,reference,range\n1,a,nan\n").find("r.csv:2: column 'range': 'nan' is not a finite"),
            std::string::npos);
  EXPECT_NE(error_of("fix,reference,range\n1,a,2\n1,a,x\n").find("r.csv:3: column 'range': 'x' is not a number"),
            std::string::npos);
  EXPECT_NE(error_of("fix,reference,range\n1,a,-1\n").find("r.csv:2: column 'range': negative"), std::string::npos);
  EXPECT_NE(error_of("fix,reference,range\n1,zz,1\n").find("r.csv:2: reference 'zz' is not in the anchors file"),
            std::string::npos);
  EXPECT_NE(error_of("fix,reference,range\n1,a\n").find("r.csv:2: 2 fields, the header has 3"), std::string::npos);
  EXPECT_NE(error_of("fix,reference,range,sigma\n1,a,1,0\n").find("r.csv:2: column 'sigma': must be > 0"),
            std::string::npos);
  EXPECT_NE(error_of("fix,reference,range,ref_x,ref_y\n").find("ref_x, ref_y and ref_z come together"),
            std::string::npos);
}

class TrilaterateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("ips_trilaterate_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string path(const char* name) const { return (dir_ / name).string(); }
  void write(const char* name, const std::string& text) const { std::ofstream(dir_ / name) << text; }
  std::string read(const char* name) const {
    std::ifstream in(dir_ / name);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  std::filesystem::path dir_;
};

TEST_F(TrilaterateCli, FixesMatchTheTruthAndUnsolvableOnesAreNamed) {
  write("anchors.yaml",
        "anchors:\n  - {id: n, x: 0, y: 0, z: 2.5}\n  - {id: e, x: 6, y: 0, z: 0.5}\n"
        "  - {id: s, x: 6, y: 4, z: 2.5}\n  - {id: w, x: 0, y: 4, z: 0.8}\n  - {id: top, x: 3, y: 2, z: 3.0}\n");
  // Fix "p" at (2, 1.5, 1.3) from exact ranges; fix "q" has only three ranges.
  const Eigen::Vector3d truth(2.0, 1.5, 1.3);
  const std::vector<std::pair<std::string, Eigen::Vector3d>> anchors = {
      {"n", {0, 0, 2.5}}, {"e", {6, 0, 0.5}}, {"s", {6, 4, 2.5}}, {"w", {0, 4, 0.8}}, {"top", {3, 2, 3.0}}};
  std::string csv = "fix,reference,range,sigma\n";
  for (const auto& [id, a] : anchors) csv += "p," + id + "," + std::to_string((a - truth).norm()) + ",0.05\n";
  csv += "q,n,1,0.05\nq,e,1,0.05\nq,s,1,0.05\n";
  write("ranges.csv", csv);
  for (const char* method : {"robust", "lsq", "median4", "mean4", "nelder-mead"}) {
    const auto r =
        test::run_program("ips", "trilaterate --anchors " + path("anchors.yaml") + " --ranges " + path("ranges.csv") +
                                     " --out " + path("fixes.csv") + " --method " + method);
    ASSERT_EQ(r.status, 0) << method << ": " << r.out;
    EXPECT_NE(r.out.find("1 of 2 fixes solved"), std::string::npos) << r.out;
    std::istringstream fixes(read("fixes.csv"));
    std::string header, p, q;
    std::getline(fixes, header);
    std::getline(fixes, p);
    std::getline(fixes, q);
    EXPECT_EQ(header, "fix,x,y,z,cxx,cxy,cxz,cyy,cyz,czz,n,status");
    double x = 0, y = 0, z = 0;
    ASSERT_EQ(std::sscanf(p.c_str(), "p,%lf,%lf,%lf,", &x, &y, &z), 3) << p;
    EXPECT_NEAR(x, 2.0, 1e-4) << method;
    EXPECT_NEAR(y, 1.5, 1e-4) << method;
    EXPECT_NEAR(z, 1.3, 1e-4) << method;
    EXPECT_NE(p.find(",5,ok"), std::string::npos) << p;
    EXPECT_EQ(q, "q,,,,,,,,,,0,too_few");
  }
}

TEST_F(TrilaterateCli, BadInputExitsTwoNamingTheFileAndLine) {
  write("anchors.yaml", "anchors:\n  - {id: a, x: 0, y: 0, z: 0}\n  - {id: a, x: 1, y: 0, z: 0}\n");
  write("ranges.csv", "fix,reference,range\n1,a,1\n");
  auto r = test::run_program("ips", "trilaterate --anchors " + path("anchors.yaml") + " --ranges " +
                                        path("ranges.csv") + " --out " + path("fixes.csv"));
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("anchors[1].id: 'a' is given twice"), std::string::npos) << r.out;
  write("anchors.yaml", "anchors:\n  - {id: a, x: 0, y: 0, z: 0, w: 1}\n");
  r = test::run_program("ips", "trilaterate --anchors " + path("anchors.yaml") + " --ranges " + path("ranges.csv") +
                                   " --out " + path("fixes.csv"));
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("anchors.yaml:2:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("unknown key"), std::string::npos) << r.out;
  write("anchors.yaml", "anchors:\n  - {id: a, x: 0, y: 0, z: 0}\n");
  write("ranges.csv", "fix,reference,range\n1,a,1\n1,b,2\n");
  r = test::run_program("ips", "trilaterate --anchors " + path("anchors.yaml") + " --ranges " + path("ranges.csv") +
                                   " --out " + path("fixes.csv"));
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("ranges.csv:3: reference 'b' is not in the anchors file"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(path("fixes.csv")));
}

}  // namespace
}  // namespace ips
