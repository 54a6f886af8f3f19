// Bodies in the simulator (markers on planes of any orientation, exact body truth) and the
// per-observation estimate on exact corners (independent truth: the scene's body pose).
#include <cmath>
#include <filesystem>
#include <fstream>

#include <unistd.h>
#include <numbers>

#include <gtest/gtest.h>

#include "body_lab.h"
#include "ips/core/error.h"

namespace {

using ips::test::BodyLab;

constexpr double kDeg = std::numbers::pi / 180.0;

// Scratch folders of this process, removed when it exits.
struct Scratch {
  std::vector<std::filesystem::path> dirs;
  ~Scratch() {
    std::error_code ec;
    for (const auto& d : dirs) std::filesystem::remove_all(d, ec);
  }
} scratch;

std::string temp_dir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() / ("ips_body_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  scratch.dirs.push_back(d);
  return d.string();
}

// A static cube robot south of camera white, a two-marker robot, and a tilted (non-ground) drone.
const char* kBodies = R"(bodies:
  - name: turtle
    x: 1.0
    y: 0.6
    yaw_deg: 30
    cube: {id: 5, edge: 0.075, size: 0.10, height: 0.30}
  - name: long
    x: 1.4
    y: 3.0
    yaw_deg: -60
    edge: 0.10
    flat: [{id: 7, offset: [0.2, 0, 0.25]}, {id: 8, offset: [-0.2, 0, 0.25]}]
  - name: drone
    ground: false
    x: 3.3
    y: 2.0
    height: 0.8
    yaw_deg: 150
    roll_deg: 12
    pitch_deg: -8
    markers: [{id: 9, edge: 0.12, position: [0, 0, 0.02]}]
)";

TEST(BodyScene, TruthOfTiltedFaces) {
  BodyLab lab(kBodies, temp_dir("truth"));
  const auto& s = lab.scene();
  ASSERT_EQ(s.bodies.size(), 3u);
  ASSERT_EQ(s.markers.size(), 5u + 2u + 1u);
  const ips::BodyPose turtle = s.body_pose_at(0, 0.0);
  EXPECT_TRUE(turtle.position.isApprox(Eigen::Vector3d(1.0, 0.6, 0.0)));
  EXPECT_NEAR(turtle.yaw, 30 * kDeg, 1e-12);
  // Face 1 of the cube (+x) at yaw 30: centre 5 cm along (cos 30, sin 30) at mid-height 0.35.
  const ips::sim::MarkerPose side = s.marker_pose_at(1, 0.0);
  EXPECT_NEAR(side.x, 1.0 + 0.05 * std::cos(30 * kDeg), 1e-12);
  EXPECT_NEAR(side.y, 0.6 + 0.05 * std::sin(30 * kDeg), 1e-12);
  EXPECT_NEAR(side.z, 0.35, 1e-12);
  EXPECT_TRUE(side.frame().col(2).isApprox(Eigen::Vector3d(std::cos(30 * kDeg), std::sin(30 * kDeg), 0), 1e-12));
  EXPECT_TRUE(side.frame().col(1).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  // The drone's quaternion is yaw * pitch * roll.
  const ips::BodyPose drone = s.body_pose_at(2, 0.0);
  const Eigen::Matrix3d R = drone.q.toRotationMatrix();
  EXPECT_NEAR(std::atan2(R(1, 0), R(0, 0)), 150 * kDeg, 1e-9);
  EXPECT_NEAR(std::asin(-R(2, 0)), -8 * kDeg, 1e-9);
  EXPECT_NEAR(std::atan2(R(2, 1), R(2, 2)), 12 * kDeg, 1e-9);

  // Camera red (at 2.34, 0.92; the cube 1.4 m west of it) sees the top and the faces turned to it, not the others.
  const auto truth = lab.renderer(0).truth(0.0);
  const Eigen::Vector3d cam = s.cameras[0].position;
  for (std::size_t i = 0; i < 5; ++i) {
    const Eigen::Vector3d f = s.marker_pose_at(i, 0.0).frame().col(2);
    const bool facing = f.dot(cam - Eigen::Vector3d(truth[i].pose.x, truth[i].pose.y, truth[i].pose.z)) > 0;
    if (!facing) {
      EXPECT_FALSE(truth[i].visible) << "face " << i;
    }
  }
  EXPECT_TRUE(truth[0].visible);   // top
  EXPECT_TRUE(truth[1].visible);   // the face turned to 30 deg, towards the camera
  EXPECT_FALSE(truth[2].visible);  // 120 deg and 210 deg: turned away
  EXPECT_FALSE(truth[3].visible);
}

TEST(BodyScene, RenderedTiltedFacesAreDetectedWhereTruthSaysAndOnlyThere) {
  BodyLab lab(kBodies, temp_dir("render"));
  ips::Detector detector;
  cv::Mat gray;
  int matched_sides = 0;
  for (std::size_t c = 0; c < 3; ++c) {
    lab.renderer(c).render(0.0, gray, c);
    const auto truth = lab.renderer(c).truth(0.0);
    const auto dets = detector.detect(gray, &lab.renderer(c).camera().model);
    const cv::Size size = lab.renderer(c).camera().model.size();
    for (const auto& d : dets) {
      bool inside = true;  // a marker cut by the image border has no full truth to compare with
      for (const auto& p : d.corners_px)
        inside = inside && p.x > 10 && p.y > 10 && p.x < size.width - 11 && p.y < size.height - 11;
      if (!inside) continue;
      // The truth of the same id whose corners lie nearest: within half a pixel each.
      double best = 1e9;
      std::size_t which = 0;
      for (std::size_t i = 0; i < truth.size(); ++i) {
        if (truth[i].id != d.id || !truth[i].visible) continue;
        double worst = 0;
        for (int k = 0; k < 4; ++k)
          worst = std::max(worst, std::hypot(d.corners_px[k].x - truth[i].corners_px[k].x,
                                             d.corners_px[k].y - truth[i].corners_px[k].y));
        if (worst < best) {
          best = worst;
          which = i;
        }
      }
      EXPECT_LT(best, 0.5) << "camera " << c << " id " << d.id;
      if (d.id == 5 && which >= 1 && which <= 4 && best < 0.5) ++matched_sides;
    }
  }
  EXPECT_GE(matched_sides, 1);  // a side face of the cube is found on its tilted plane
}

TEST(BodyEstimate, ExactCornersGiveTheBodyPose) {
  BodyLab lab(kBodies, temp_dir("exact"));
  std::vector<ips::BodyObservation> all;
  int sides = 0;
  for (std::size_t c = 0; c < 3; ++c) {
    const auto& model = lab.renderer(c).camera().model;
    for (const auto& t : lab.renderer(c).truth(0.0)) {
      if (!t.visible) continue;
      ips::MarkerDetection d;
      d.id = t.id;
      d.corners_px = t.corners_px;
      double edge = 0;
      for (const auto& b : lab.estimator().bodies())
        for (const auto& m : b.markers)
          if (m.id == t.id) edge = m.edge;
      const ips::CameraObservation obs = ips::locate_marker(d, model, edge);
      ips::BodyObservation bo;
      std::string why;
      if (lab.estimator().observe(obs, lab.mapper(c), static_cast<int>(c), 0, 0, bo, &why)) {
        all.push_back(bo);
        if (bo.id == 5 && bo.face == ips::FaceClass::kSide) {
          ++sides;
          EXPECT_EQ(bo.faces.size(), 4u);  // a cube side: which of four is told by the yaw
        }
      }
    }
  }
  EXPECT_GE(sides, 2);
  const auto fused = lab.estimator().fuse(all, ips::find_fusion_method("mean", "test"));
  ASSERT_EQ(fused.size(), 3u);
  for (const auto& f : fused) {
    const ips::BodyPose truth = lab.scene().body_pose_at(static_cast<std::size_t>(f.body), 0.0);
    SCOPED_TRACE(f.name);
    EXPECT_TRUE(f.has_yaw);
    // The plane models are fitted on 30 exact pairs: sub-millimetre.
    EXPECT_LT((f.pose.position - truth.position).norm(), f.body == 2 ? 0.005 : 0.001);
    EXPECT_LT(std::abs(ips::test::wrap_angle(f.pose.yaw - truth.yaw)), 0.2 * kDeg);
    EXPECT_LT(f.pose.q.angularDistance(truth.q), f.body == 2 ? 0.5 * kDeg : 0.2 * kDeg);
  }
}

TEST(BodyScene, BadBodiesInASceneNameTheKey) {
  const std::string dir = temp_dir("bad");
  auto load = [&](const std::string& bodies) -> std::string {
    std::ofstream(dir + "/bad.yaml") << ips::test::published_scene_with("markers: []\n" + bodies);
    try {
      ips::sim::Scene::load(dir + "/bad.yaml");
    } catch (const ips::InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(load("bodies:\n  - {name: a, x: 1, y: 1, cube: {id: 5, edge: 0.05, size: 0}}").find("bodies[0].cube.size"),
            std::string::npos);
  EXPECT_NE(load("bodies:\n  - {name: a, x: 1, y: 1, cube: {id: 5, edge: 0.05, size: 0.1}}\n"
                 "  - {name: b, x: 2, y: 1, cube: {id: 5, edge: 0.05, size: 0.1}}")
                .find("marker id 5 is already used by body 'a'"),
            std::string::npos);
  EXPECT_NE(load("bodies:\n  - {name: a, y: 1, cube: {id: 5, edge: 0.05, size: 0.1}}").find("bodies[0].x: missing"),
            std::string::npos);
}

}  // namespace

namespace {

// A cube's side alone cannot tell which of four faces it is: position only, until the body's
// yaw is known (from its top at the same instant, or from the last second).
TEST(BodyEstimate, CubeSidesNeedAYawToTellTheirFace) {
  BodyLab lab(kBodies, temp_dir("sides"));
  std::vector<ips::BodyObservation> sides, tops;
  for (std::size_t c = 0; c < 3; ++c) {
    const auto truth = lab.renderer(c).truth(0.0);
    for (std::size_t i = 0; i < 5; ++i) {  // the cube's faces
      if (!truth[i].visible) continue;
      ips::MarkerDetection d;
      d.id = truth[i].id;
      d.corners_px = truth[i].corners_px;
      ips::BodyObservation bo;
      if (!lab.estimator().observe(ips::locate_marker(d, lab.renderer(c).camera().model, 0.075), lab.mapper(c),
                                   static_cast<int>(c), 0, 0, bo))
        continue;
      (bo.face == ips::FaceClass::kSide ? sides : tops).push_back(bo);
    }
  }
  ASSERT_FALSE(sides.empty());
  ASSERT_FALSE(tops.empty());
  const auto& mean = ips::find_fusion_method("mean", "test");
  const ips::BodyPose truth = lab.scene().body_pose_at(0, 0.0);
  auto at = [](std::vector<ips::BodyObservation> v, std::int64_t t) {
    for (auto& o : v) o.t_mono_ns = t;
    return v;
  };
  // Sides only, nothing known: the position (the cube's centre is half a side behind any side).
  auto f = lab.estimator().fuse(at(sides, 0), mean);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_FALSE(f[0].has_yaw);
  EXPECT_LT((f[0].pose.position - truth.position).norm(), 0.001);
  // The top at the same instant: the sides join with their face told.
  std::vector<ips::BodyObservation> both = at(sides, 100'000'000);
  for (const auto& o : at(tops, 100'000'000)) both.push_back(o);
  f = lab.estimator().fuse(both, mean);
  ASSERT_TRUE(f[0].has_yaw);
  EXPECT_LT(std::abs(ips::test::wrap_angle(f[0].pose.yaw - truth.yaw)), 0.2 * kDeg);
  EXPECT_EQ(f[0].observations, static_cast<int>(both.size()));
  // Half a second later, sides only: the remembered yaw tells the face.
  f = lab.estimator().fuse(at(sides, 600'000'000), mean);
  ASSERT_TRUE(f[0].has_yaw);
  EXPECT_LT(std::abs(ips::test::wrap_angle(f[0].pose.yaw - truth.yaw)), 0.2 * kDeg);
  // Two seconds after the last yaw: forgotten, position only again.
  f = lab.estimator().fuse(at(sides, 2'700'000'000), mean);
  EXPECT_FALSE(f[0].has_yaw);
}

}  // namespace
