#include "ips/mapping/calib_data.h"

#include <gtest/gtest.h>

#include <sstream>

#include "ips/core/error.h"
#include "test_util.h"

namespace {

ips::CalibData parse(const std::string& text) {
  std::istringstream in(text);
  return ips::parse_calib_csv(in, "t.csv");
}

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const ips::InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(CalibCsv, ReadsColumnsInAnyOrderAndIgnoresExtras) {
  const auto data = parse(
      "zw,note,camera,xc,yc,zc,xw,yw\r\n"
      "0.1,a,red,1,2,3,4,5\r\n"
      "\n"
      "0.2, b , white ,-1.5e-1,+2,3,4,5\n"
      "0,c,red,7,8,9,10,11\n");
  ASSERT_EQ(data.cameras.size(), 2u);
  const auto* red = data.find("red");
  ASSERT_NE(red, nullptr);
  ASSERT_EQ(red->cam.size(), 2u);
  EXPECT_EQ(red->cam[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(red->world[0], Eigen::Vector3d(4, 5, 0.1));
  EXPECT_EQ(red->world[1], Eigen::Vector3d(10, 11, 0));
  EXPECT_EQ(red->lines, (std::vector<std::size_t>{2, 5}));
  const auto* white = data.find("white");
  ASSERT_NE(white, nullptr);
  EXPECT_EQ(white->cam[0], Eigen::Vector3d(-0.15, 2, 3));
  EXPECT_EQ(data.camera_list(), "red, white");
}

TEST(CalibCsv, LoadsThePublishedDataset) {
  const auto data = ips::load_calib_csv(ips::test::train40_path());
  ASSERT_EQ(data.cameras.size(), 3u);
  for (const char* cam : {"red", "white", "black"}) {
    ASSERT_NE(data.find(cam), nullptr) << cam;
    EXPECT_EQ(data.find(cam)->cam.size(), 40u) << cam;
  }
  // First data row of the file (line 2), as printed in it.
  EXPECT_DOUBLE_EQ(data.cameras[0].cam[0].x(), -2.20981422);
  EXPECT_DOUBLE_EQ(data.cameras[0].world[0].x(), 0.13643);
}

TEST(CalibCsv, MissingColumnNamesFileLineAndColumn) {
  EXPECT_EQ(error_of("camera,xc,yc,xw,yw,zw\nred,1,2,3,4,5\n"),
            "t.csv:1: missing required column 'zc' (header must name camera,xc,yc,zc,xw,yw,zw)");
}

TEST(CalibCsv, NonNumericValue) {
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1,2,3,4,5,6\nred,1,abc,3,4,5,6\n"),
            "t.csv:3: column 'yc' (3): 'abc' is not a number");
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1,2,3,4,5,6x\n"), "t.csv:2: column 'zw' (7): '6x' is not a number");
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1,2,,4,5,6\n"), "t.csv:2: column 'zc' (4): empty value");
}

TEST(CalibCsv, NonFiniteValue) {
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1,2,3,nan,5,6\n"),
            "t.csv:2: column 'xw' (5): 'nan' is not a finite number");
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1,2,3,4,-inf,6\n"),
            "t.csv:2: column 'yw' (6): '-inf' is not a finite number");
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1e999,2,3,4,5,6\n"),
            "t.csv:2: column 'xc' (2): value '1e999' is out of range");
}

TEST(CalibCsv, WrongFieldCount) {
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\nred,1,2,3,4,5,6\nred,1,2,3,4,5\n"),
            "t.csv:3: 6 fields, the header has 7");
}

TEST(CalibCsv, EmptyCameraName) {
  EXPECT_EQ(error_of("xc,yc,zc,xw,yw,zw,camera\n1,2,3,4,5,6,\n"), "t.csv:2: column 'camera' (7): empty camera name");
}

TEST(CalibCsv, EmptyFileNoRowsDuplicateColumn) {
  EXPECT_NE(error_of("").find("t.csv: empty file"), std::string::npos);
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw\n\n"), "t.csv: no data rows after the header");
  EXPECT_EQ(error_of("camera,xc,yc,zc,xw,yw,zw,xc\nred,1,2,3,4,5,6,7\n"), "t.csv:1: column 'xc' appears twice");
}

TEST(CalibCsv, UnreadableFile) { EXPECT_THROW(ips::load_calib_csv("/nonexistent/x.csv"), ips::InputError); }

}  // namespace
