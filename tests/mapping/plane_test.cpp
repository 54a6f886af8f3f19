// The plane mapper against a synthetic camera with exactly known pose.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "ips/core/error.h"
#include "ips/mapping/cross_validation.h"
#include "ips/mapping/mapper.h"

#include <nlohmann/json.hpp>
#include "test_util.h"

namespace {

using Points = std::vector<Eigen::Vector3d>;

struct Scene {
  Eigen::Matrix3d R;  // camera -> world rotation
  Eigen::Vector3d t;  // camera centre in the world
  Points cam, world;
};

// A ceiling camera looking down (camera z towards the floor), tilted a few degrees, and
// markers on a floor grid at heights 0..0.2 m. The camera coordinates get a 3 % random depth
// error (as from the marker-size formula), which moves (xc, yc, zc) along the ray only.
Scene make_scene(double depth_noise, double k1 = 0.0) {
  Scene s;
  s.R = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(M_PI + 0.05, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(-0.03, Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
  s.t = Eigen::Vector3d(2.4, 2.2, 2.1);
  const auto noise = ips::test::gaussian_noise(64, depth_noise, 5);
  int i = 0;
  for (int gx = 0; gx < 8; ++gx)
    for (int gy = 0; gy < 8; ++gy, ++i) {
      const Eigen::Vector3d w(0.5 + 0.55 * gx, 0.4 + 0.55 * gy, 0.05 * (i % 5));
      Eigen::Vector3d c = s.R.transpose() * (w - s.t);
      if (k1 != 0.0) {
        // The observed normalised point carries radial distortion the model must undo:
        // observed u_d with u_d (1 + k1 r_d^2) = u (solved by fixed-point iteration).
        const Eigen::Vector2d u = c.head<2>() / c.z();
        Eigen::Vector2d ud = u;
        for (int it = 0; it < 50; ++it) ud = u / (1.0 + k1 * ud.squaredNorm());
        c = Eigen::Vector3d(ud.x(), ud.y(), 1.0) * c.z();
      }
      s.cam.push_back(c * (1.0 + noise[static_cast<std::size_t>(i)]));
      s.world.push_back(w);
    }
  return s;
}

TEST(PlaneMapper, RecoversASyntheticCameraPoseDespiteDepthNoise) {
  const Scene s = make_scene(0.03);
  auto plane = ips::make_mapper("plane");
  EXPECT_TRUE(plane->needs_height());
  plane->fit(s.cam, s.world, {});
  const nlohmann::json p = plane->to_json();
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = p["R"][r][c].get<double>();
  EXPECT_LT((R - s.R).norm(), 1e-6);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(p["t"][k].get<double>(), s.t[k], 1e-6);
  // A new marker at a new height: exact, and its z is the given height.
  const Eigen::Vector3d w(1.23, 3.21, 0.12);
  const Eigen::Vector3d c = s.R.transpose() * (w - s.t) * 0.9;  // wrong depth on purpose
  const Eigen::Vector3d hat = plane->predict(c, w.z());
  EXPECT_LT((hat - w).norm(), 1e-6);
  EXPECT_EQ(hat.z(), 0.12);
  EXPECT_THROW(plane->predict(c), ips::InputError);  // no height given
}

TEST(PlaneMapper, WorldRayStartsAtTheCameraAndPassesThroughTheMarker) {
  const Scene s = make_scene(0.03);
  auto plane = ips::make_mapper("plane");
  plane->fit(s.cam, s.world, {});
  // The ray through a camera point whatever its depth: origin = the true camera centre, and
  // the true marker lies on it (what triangulation relies on).
  const Eigen::Vector3d w(1.23, 3.21, 0.12);
  const Eigen::Vector3d c = s.R.transpose() * (w - s.t) * 1.1;  // wrong depth on purpose
  Eigen::Vector3d origin, direction;
  ASSERT_TRUE(plane->world_ray(c, origin, direction));
  EXPECT_LT((origin - s.t).norm(), 1e-6);
  EXPECT_NEAR(direction.norm(), 1.0, 1e-12);
  const Eigen::Vector3d r = w - origin;
  EXPECT_LT((r - r.dot(direction) * direction).norm(), 1e-6);
  EXPECT_GT(r.dot(direction), 0.0);  // in front of the camera
  // A mapper without a pose gives no ray.
  auto rt = ips::make_mapper("rt");
  rt->fit(s.cam, s.world, {});
  EXPECT_FALSE(rt->world_ray(c, origin, direction));
}

TEST(PlaneMapper, BeatsPolynomialIn2DWhenDepthIsNoisy) {
  const Scene s = make_scene(0.01);
  const auto plane = ips::cross_validate("plane", s.cam, s.world, 4, {});
  const auto pr = ips::cross_validate("pr", s.cam, s.world, 4, {});
  EXPECT_LT(plane.err2d.mean, 1e-6);
  EXPECT_GT(pr.err2d.mean, 1e-3);
}

TEST(PlaneMapper, RadialCorrectionUndoesResidualDistortion) {
  const Scene s = make_scene(0.0, 0.02);
  auto plane = ips::make_mapper("plane");
  plane->fit(s.cam, s.world, {});
  EXPECT_GE(plane->to_json()["radial_terms"].get<int>(), 1);
  double worst = 0.0;
  for (std::size_t i = 0; i < s.cam.size(); ++i)
    worst = std::max(worst, (plane->predict(s.cam[i], s.world[i].z()) - s.world[i]).norm());
  EXPECT_LT(worst, 1e-3);  // 1 mm; without the correction the edge error is several cm
}

}  // namespace

namespace {

// auto on the same scene: with the 2d metric it must find plane (exact in 2-D while every
// other method suffers the depth noise); with 3d plane is not a candidate, and the choice is
// the argmin of the CV table it records.
TEST(AutoMapper, PicksTheBestCrossValidatedMethod) {
  const Scene s = make_scene(0.01);
  const std::vector<Eigen::Vector3d> cam(s.cam.begin(), s.cam.begin() + 24);
  const std::vector<Eigen::Vector3d> world(s.world.begin(), s.world.begin() + 24);
  ips::FitOptions options;
  options.folds = 2;
  options.metric = ips::ErrorMetric::k2d;  // heights known: the default
  auto a2 = ips::make_mapper("auto");
  a2->fit(cam, world, options);
  EXPECT_EQ(a2->to_json()["chosen"], "plane");
  EXPECT_TRUE(a2->needs_height());

  // Heights known (the default) under the 3-D metric: plane competes with its true error,
  // which is its 2-D error (its z is the given height), and wins here.
  options.metric = ips::ErrorMetric::k3d;
  auto known = ips::make_mapper("auto");
  known->fit(cam, world, options);
  const nlohmann::json k = known->to_json();
  EXPECT_EQ(k["chosen"], "plane");
  EXPECT_EQ(k["heights_known"], true);
  EXPECT_EQ(k["cv_mean_error"]["plane"]["err3d_mean"], k["cv_mean_error"]["plane"]["err2d_mean"]);

  // Heights unknown: plane cannot be used and does not compete.
  options.heights_known = false;
  auto a3 = ips::make_mapper("auto");
  a3->fit(cam, world, options);
  const nlohmann::json p = a3->to_json();
  EXPECT_FALSE(p["cv_mean_error"].contains("plane"));
  EXPECT_EQ(p["heights_known"], false);
  std::string best;
  double best_err = 1e9;
  for (const auto& [name, row] : p["cv_mean_error"].items())
    if (row.contains("err3d_mean") && row["err3d_mean"].get<double>() < best_err) {
      best_err = row["err3d_mean"].get<double>();
      best = name;
    }
  EXPECT_EQ(p["chosen"], best);
  // The recorded CV error of the choice is what cross_validate reports for it.
  EXPECT_NEAR(ips::cross_validate(best, cam, world, 2, options).err3d.mean, best_err, 1e-12);
}

}  // namespace
