// The ceiling map: its corner convention computed by hand, its file read strictly.
#include <gtest/gtest.h>

#include "ips/core/error.h"
#include "ips/insideout/ceiling_map.h"

namespace ips {
namespace {

TEST(CeilingMap, CornersOfAMarkerSeenFromBelowReadAsPrinted) {
  // Yaw 0: x axis = world +x, normal = world -z, so the printed y axis (n x x) is world -y.
  // The top-left corner (-0.5, +0.5 marker units) is then at (-L/2, -L/2) from the centre.
  CeilingMarker m;
  m.centre = {2.0, 1.0, 3.0};
  m.length = 0.4;
  const auto c = m.corners();
  EXPECT_NEAR(c[0].x(), 1.8, 1e-12);
  EXPECT_NEAR(c[0].y(), 0.8, 1e-12);
  EXPECT_NEAR(c[1].x(), 2.2, 1e-12);
  EXPECT_NEAR(c[1].y(), 0.8, 1e-12);
  EXPECT_NEAR(c[2].x(), 2.2, 1e-12);
  EXPECT_NEAR(c[2].y(), 1.2, 1e-12);
  EXPECT_NEAR(c[3].x(), 1.8, 1e-12);
  EXPECT_NEAR(c[3].y(), 1.2, 1e-12);
  for (const auto& p : c) EXPECT_DOUBLE_EQ(p.z(), 3.0);
  // A camera below looking up with image x = world x, image y = world y sees the top-left
  // corner top left, the top-right one to its right: the marker reads as printed.
  // Turned by 90 degrees: the printed x axis points along world +y, the printed y along +x:
  // top-left = centre + L(-0.5 (0, 1) + 0.5 (1, 0)) = (2.2, 0.8), top-right = (2.2, 1.2).
  m.yaw = M_PI / 2;
  const auto d = m.corners();
  EXPECT_NEAR(d[0].x(), 2.2, 1e-12);
  EXPECT_NEAR(d[0].y(), 0.8, 1e-12);
  EXPECT_NEAR(d[1].x(), 2.2, 1e-12);
  EXPECT_NEAR(d[1].y(), 1.2, 1e-12);
}

TEST(CeilingMap, RoundTripsThroughItsJson) {
  CeilingMap map;
  map.dictionary = "DICT_5X5_50";
  CeilingMarker a;
  a.id = 7;
  a.centre = {1.25, -0.5, 2.8};
  a.yaw = -2.5;
  a.length = 0.3;
  a.sigma = Eigen::Vector4d(0.001, 0.002, 0.003, 0.004);
  CeilingMarker b;
  b.id = 9;
  map.markers = {a, b};
  const CeilingMap back = CeilingMap::parse(map.to_json(), "map.json");
  EXPECT_EQ(back.dictionary, "DICT_5X5_50");
  ASSERT_EQ(back.markers.size(), 2u);
  EXPECT_EQ(back.markers[0].id, 7);
  EXPECT_EQ(back.markers[0].centre, a.centre);
  EXPECT_EQ(back.markers[0].yaw, a.yaw);
  EXPECT_EQ(back.markers[0].length, a.length);
  ASSERT_TRUE(back.markers[0].sigma.has_value());
  EXPECT_EQ(*back.markers[0].sigma, *a.sigma);
  EXPECT_FALSE(back.markers[1].sigma.has_value());
  EXPECT_EQ(back.find(9), &back.markers[1]);
  EXPECT_EQ(back.find(8), nullptr);
}

void expect_refused(const std::string& text, const std::string& part) {
  try {
    CeilingMap::parse(text, "lab/map.json");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(CeilingMap, BadFilesAreRefusedNamingTheEntry) {
  const std::string head = R"({"format": "ips-ceiling-map", "version": 1, "markers": )";
  expect_refused("{", "lab/map.json: not JSON");
  // A number beyond a double: nlohmann::json's out_of_range, not a parse_error (found by fuzz_ceiling_map).
  expect_refused(head + R"([{"id": 1, "x": 0, "y": 0, "z": 3, "yaw": -1e3081, "length": 0.2}]})",
                 "lab/map.json: not JSON");
  expect_refused(R"({"format": "ips-record", "version": 1, "markers": []})", "format");
  expect_refused(R"({"format": "ips-ceiling-map", "version": 2, "markers": []})", "version");
  expect_refused(head + "[]}", "markers: expected a non-empty list");
  expect_refused(head + R"([{"id": 1, "x": 0, "y": 0, "z": 3, "yaw": 0}]})", "markers[0].length: missing");
  expect_refused(head + R"([{"id": 1, "x": "1", "y": 0, "z": 3, "yaw": 0, "length": 0.2}]})",
                 "markers[0].x: expected a number");
  expect_refused(head + R"([{"id": 1, "x": 0, "y": 0, "z": 3, "yaw": 0, "length": -0.2}]})",
                 "markers[0].length: must be");
  expect_refused(head + R"([{"id": 1.5, "x": 0, "y": 0, "z": 3, "yaw": 0, "length": 0.2}]})",
                 "markers[0].id: must be a non-negative integer");
  expect_refused(head + R"([{"id": 1, "x": 0, "y": 0, "z": 3, "yaw": 0, "length": 0.2},
                            {"id": 1, "x": 1, "y": 0, "z": 3, "yaw": 0, "length": 0.2}]})",
                 "markers[1].id: duplicate marker id 1");
  expect_refused(head + R"([{"id": 1, "x": 0, "y": 0, "z": 3, "yaw": 0, "length": 0.2, "sigma": [1, 2]}]})",
                 "markers[0].sigma");
  expect_refused(R"({"format": "ips-ceiling-map", "version": 1, "dictionary": "DICT_9X9", "markers": []})",
                 "dictionary");
  EXPECT_THROW(CeilingMap::load("/nonexistent/map.json"), InputError);
}

}  // namespace
}  // namespace ips
