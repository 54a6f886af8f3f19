// Body definitions: face frames, the cube helper, the strict parser's errors.
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "ips/body/body.h"
#include "ips/core/error.h"

namespace {

using ips::BodyDef;
using ips::BodyMarker;

ips::BodyFail thrower() {
  return [](const YAML::Node& at, const std::string& key, const std::string& what) {
    throw ips::InputError("test.yaml:" + std::to_string(at.Mark().line + 1) + ": " + key + ": " + what);
  };
}

std::vector<BodyDef> parse_all(const std::string& text) {
  const YAML::Node root = YAML::Load(text);
  std::vector<BodyDef> defs;
  std::vector<YAML::Node> nodes;
  for (std::size_t i = 0; i < root.size(); ++i) {
    defs.push_back(ips::parse_body(root[i], "bodies[" + std::to_string(i) + "]", {}, thrower()));
    nodes.push_back(root[i]);
  }
  ips::check_bodies(defs, nodes, "bodies", thrower());
  return defs;
}

std::string error_of(const std::string& text) {
  try {
    parse_all(text);
  } catch (const ips::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BodyGeometry, FaceAxesAreRightHandedWithUprightSides) {
  // Top face: x = body x, y = body y.
  const Eigen::Matrix3d top = ips::face_axes({0, 0, 1}, 0.0);
  EXPECT_TRUE(top.isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  // A side face reads upright: its y is body z, its x is z x n (right when facing it).
  const Eigen::Matrix3d side = ips::face_axes({1, 0, 0}, 0.0);
  EXPECT_TRUE(side.col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));
  EXPECT_TRUE(side.col(1).isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  for (const auto& n : {Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(0, 0, -1)}) {
    const Eigen::Matrix3d a = ips::face_axes(n, 0.3);
    EXPECT_NEAR(a.determinant(), 1.0, 1e-12);
    EXPECT_TRUE((a.transpose() * a).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
    EXPECT_TRUE(a.col(2).isApprox(n.normalized(), 1e-12));
  }
  // Roll turns the marker counter-clockwise seen from the front.
  const Eigen::Matrix3d rolled = ips::face_axes({0, 0, 1}, M_PI / 2);
  EXPECT_TRUE(rolled.col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));
}

TEST(BodyGeometry, CubeHasFiveFacesOnItsSurface) {
  const auto faces = ips::cube_markers(5, 0.075, 0.10, 0.30);
  ASSERT_EQ(faces.size(), 5u);
  const Eigen::Vector3d centre(0, 0, 0.35);
  for (const auto& f : faces) {
    EXPECT_EQ(f.id, 5);
    // Each face centre lies half a side from the cube's centre along its own normal.
    EXPECT_TRUE((f.position - centre).isApprox(0.05 * f.axes.col(2), 1e-12));
    EXPECT_EQ(ips::face_class(f.axes.col(2), 0.1), f.axes(2, 2) > 0.5 ? ips::FaceClass::kUp : ips::FaceClass::kSide);
  }
  for (std::size_t i = 0; i < faces.size(); ++i)
    for (std::size_t j = i + 1; j < faces.size(); ++j) EXPECT_EQ(ips::marker_overlap(faces[i], faces[j]), "");
}

TEST(BodyGeometry, OverlapInOnePlane) {
  const BodyMarker a = ips::flat_marker(1, 0.10, {0, 0, 0.2}, 0.0);
  EXPECT_NE(ips::marker_overlap(a, ips::flat_marker(2, 0.10, {0.09, 0, 0.2}, 0.0)), "");
  EXPECT_EQ(ips::marker_overlap(a, ips::flat_marker(2, 0.10, {0.11, 0, 0.2}, 0.0)), "");
  // Turned 45 deg, the second square's corner reaches 0.0707 m: overlaps at 0.12, not at 0.13.
  EXPECT_NE(ips::marker_overlap(a, ips::flat_marker(2, 0.10, {0.12, 0, 0.2}, M_PI / 4)), "");
  EXPECT_EQ(ips::marker_overlap(a, ips::flat_marker(2, 0.10, {0.125, 0, 0.2}, M_PI / 4)), "");
  EXPECT_EQ(ips::marker_overlap(a, ips::flat_marker(2, 0.10, {0.05, 0, 0.25}, 0.0)), "");  // another height
}

TEST(BodyParse, HelpersAndExplicitMarkers) {
  const auto defs = parse_all(R"(
- name: turtle
  cube: {id: 5, edge: 0.075, size: 0.10, height: 0.30}
- name: long
  edge: 0.10
  flat: [{id: 7, offset: [0.2, 0]}, {id: 8, offset: [-0.2, 0, 0.05], yaw_deg: 90}]
- name: drone
  ground: false
  markers:
    - {id: 9, edge: 0.08, plate: 0.1, position: [0.1, 0, 0.05], normal: [1, 0, 0], roll_deg: 0}
)");
  ASSERT_EQ(defs.size(), 3u);
  EXPECT_EQ(defs[0].markers.size(), 5u);
  EXPECT_DOUBLE_EQ(defs[0].markers[0].position.z(), 0.40);
  ASSERT_EQ(defs[1].markers.size(), 2u);
  EXPECT_DOUBLE_EQ(defs[1].markers[1].edge, 0.10);
  EXPECT_DOUBLE_EQ(defs[1].markers[1].position.z(), 0.05);
  EXPECT_TRUE(defs[1].markers[1].axes.col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));
  EXPECT_FALSE(defs[2].ground);
  EXPECT_TRUE(defs[2].markers[0].axes.col(2).isApprox(Eigen::Vector3d(1, 0, 0), 1e-12));
}

TEST(BodyParse, BadDefinitionsNameTheKey) {
  // Zero-size cube.
  EXPECT_NE(error_of("- {name: a, cube: {id: 1, edge: 0.05, size: 0}}").find("bodies[0].cube.size: must be > 0"),
            std::string::npos);
  // An id used by two bodies.
  const std::string two = error_of(
      "- {name: a, flat: [{id: 3, edge: 0.1, offset: [0, 0]}]}\n"
      "- {name: b, cube: {id: 3, edge: 0.05, size: 0.07}}");
  EXPECT_NE(two.find("bodies[1]: marker id 3 is already used by body 'a' (bodies[0])"), std::string::npos) << two;
  // Overlapping faces.
  const std::string ov =
      error_of("- {name: a, flat: [{id: 3, edge: 0.1, offset: [0, 0]}, {id: 4, edge: 0.1, offset: [0.05, 0]}]}");
  EXPECT_NE(ov.find("bodies[0].flat[1]: overlapping faces in one plane with bodies[0].flat[0]"), std::string::npos)
      << ov;
  // A marker larger than its cube face, a typo, a missing edge, a duplicate name.
  EXPECT_NE(error_of("- {name: a, cube: {id: 1, edge: 0.2, size: 0.1}}").find("bodies[0].cube.edge"),
            std::string::npos);
  EXPECT_NE(error_of("- {name: a, cube: {id: 1, edge: 0.05, size: 0.1, hieght: 2}}")
                .find("bodies[0].cube.hieght: unknown key"),
            std::string::npos);
  EXPECT_NE(error_of("- {name: a, flat: [{id: 3, offset: [0, 0]}]}").find("bodies[0].flat[0].edge: required"),
            std::string::npos);
  EXPECT_NE(
      error_of("- {name: a, cube: {id: 1, edge: 0.05, size: 0.1}}\n- {name: a, cube: {id: 2, edge: 0.05, size: 0.1}}")
          .find("bodies[1].name: duplicate body name 'a'"),
      std::string::npos);
  EXPECT_NE(error_of("- {name: a}").find("has no markers"), std::string::npos);
  EXPECT_NE(error_of("- {name: a, markers: [{id: 1, edge: 0.1, position: [0, 0, 0], normal: [0, 0, 0]}]}")
                .find("bodies[0].markers[0].normal: must not be zero"),
            std::string::npos);
}

}  // namespace
