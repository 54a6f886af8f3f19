// rt and pr against exact synthetic truth, and rt+pr == pr on the published data.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "ips/mapping/mapper.h"

#include <nlohmann/json.hpp>
#include "test_util.h"

namespace {

using Points = std::vector<Eigen::Vector3d>;

Eigen::Matrix3d known_rotation() {
  return (Eigen::AngleAxisd(2.7, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(3.05, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(0.04, Eigen::Vector3d::UnitY()))
      .toRotationMatrix();
}

TEST(RigidMapper, RecoversAKnownPoseExactly) {
  const Eigen::Matrix3d R = known_rotation();
  const Eigen::Vector3d t(2.4, 1.9, 2.1);
  const Points cam = ips::test::random_points(25, {-2, -1.5, 1.9}, {2, 1.5, 2.2}, 7);
  Points world;
  for (const auto& c : cam) world.push_back(R * c + t);
  auto rt = ips::make_mapper("rt");
  rt->fit(cam, world, {});
  const nlohmann::json p = rt->to_json();
  Eigen::Matrix3d R_hat;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R_hat(r, c) = p["R"][r][c].get<double>();
  EXPECT_LT((R_hat - R).norm(), 1e-12);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(p["t"][k].get<double>(), t[k], 1e-12);
  const Eigen::Vector3d q(0.3, -0.2, 2.0);
  EXPECT_LT((rt->predict(q) - (R * q + t)).norm(), 1e-12);
}

// Coplanar points: the cross-covariance has rank 2 and the plain SVD solution V U^T may
// be a reflection. The proper rotation must still be recovered exactly.
TEST(RigidMapper, CoplanarPointsReflectionCaseGivesTheRotation) {
  const Eigen::Matrix3d R = known_rotation();
  const Eigen::Vector3d t(-0.5, 0.25, 1.0);
  Points cam = ips::test::random_points(12, {-1, -1, 0}, {1, 1, 0}, 3);
  for (int trial = 0; trial < 2; ++trial) {
    Points world;
    for (const auto& c : cam) world.push_back(R * c + t);
    auto rt = ips::make_mapper("rt");
    rt->fit(cam, world, {});
    for (const auto& c : cam) EXPECT_LT((rt->predict(c) - (R * c + t)).norm(), 1e-12);
    // Off the plane too: only the true rotation maps these right.
    const Eigen::Vector3d off(0.2, -0.3, 0.7);
    EXPECT_LT((rt->predict(off) - (R * off + t)).norm(), 1e-12);
    for (auto& c : cam) c = Eigen::Vector3d(c.y(), c.x(), 0.0);  // swap axes: other handedness
  }
}

// Mirrored data: no rotation fits exactly; the result must be a proper rotation (det +1)
// and the least-squares optimum among rotations: no small rotation of it fits better.
TEST(RigidMapper, MirroredDataGivesTheBestProperRotation) {
  const Points cam = ips::test::random_points(30, {-2, -2, -0.1}, {2, 2, 0.1}, 11);
  Points world;
  for (const auto& c : cam) world.push_back(Eigen::Vector3d(c.x(), c.y(), -c.z()));
  auto rt = ips::make_mapper("rt");
  rt->fit(cam, world, {});
  const nlohmann::json p = rt->to_json();
  Eigen::Matrix3d R_hat;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R_hat(r, c) = p["R"][r][c].get<double>();
  EXPECT_NEAR(R_hat.determinant(), 1.0, 1e-12);
  EXPECT_LT((R_hat.transpose() * R_hat - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // Cost of a rotation with its optimal translation (centroid alignment).
  auto cost = [&](const Eigen::Matrix3d& R) {
    Eigen::Vector3d cc = Eigen::Vector3d::Zero(), cw = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < cam.size(); ++i) {
      cc += cam[i];
      cw += world[i];
    }
    const Eigen::Vector3d t = (cw - R * cc) / static_cast<double>(cam.size());
    double s = 0.0;
    for (std::size_t i = 0; i < cam.size(); ++i) s += (R * cam[i] + t - world[i]).squaredNorm();
    return s;
  };
  const double best = cost(R_hat);
  for (int axis = 0; axis < 3; ++axis)
    for (double angle : {-1e-3, 1e-3}) {
      const Eigen::Matrix3d Rp = R_hat * Eigen::AngleAxisd(angle, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
      EXPECT_LT(best, cost(Rp)) << axis << " " << angle;
    }
  // The points spread least in z, so the best rotation is close to the identity.
  EXPECT_LT((R_hat - Eigen::Matrix3d::Identity()).norm(), 0.1);
}

TEST(RigidMapper, CollinearPointsAreRefused) {
  Points cam, world;
  for (int i = 0; i < 5; ++i) {
    cam.emplace_back(i, 2 * i, 0);
    world.emplace_back(i, 2 * i, 1);
  }
  auto rt = ips::make_mapper("rt");
  EXPECT_THROW(rt->fit(cam, world, {}), ips::InputError);
}

Eigen::Vector3d quadratic(const Eigen::Vector3d& p) {
  const double x = p.x(), y = p.y(), z = p.z();
  return {0.5 + 1.1 * x - 0.2 * y + 0.3 * z + 0.05 * x * y - 0.07 * x * z + 0.02 * y * z + 0.04 * x * x - 0.03 * y * y +
              0.01 * z * z,
          -1.0 + 0.1 * x + 0.9 * y - 0.4 * z + 0.06 * x * x + 0.08 * y * z,
          2.0 - 0.01 * x + 0.02 * y - 0.95 * z + 0.03 * z * z - 0.04 * x * y};
}

TEST(PolynomialMapper, ReproducesAnExactQuadratic) {
  const Points cam = ips::test::random_points(30, {-2, -1.5, 1.9}, {2, 1.5, 2.2}, 5);
  Points world;
  for (const auto& c : cam) world.push_back(quadratic(c));
  auto pr = ips::make_mapper("pr");
  pr->fit(cam, world, {});
  for (const auto& q : ips::test::random_points(20, {-2, -1.5, 1.9}, {2, 1.5, 2.2}, 6))
    EXPECT_LT((pr->predict(q) - quadratic(q)).norm(), 1e-9);
}

TEST(PolynomialMapper, RefusesTooFewOrDegeneratePoints) {
  const Points cam9 = ips::test::random_points(9, {-2, -1.5, 1.9}, {2, 1.5, 2.2}, 5);
  auto pr = ips::make_mapper("pr");
  EXPECT_EQ(pr->min_points(), 10u);
  EXPECT_THROW(pr->fit(cam9, cam9, {}), ips::InputError);
  // All points at one depth: 1, z and z^2 are the same column up to scale.
  Points flat = ips::test::random_points(30, {-2, -1.5, 2}, {2, 1.5, 2}, 5);
  try {
    pr->fit(flat, flat, {});
    FAIL() << "no error";
  } catch (const ips::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rank"), std::string::npos) << e.what();
  }
}

// A quadratic of a rigid transform is a quadratic: rt+pr spans the same function space as
// pr, so both give the same least-squares fit (up to rounding).
TEST(PolynomialMapper, RtPlusPrEqualsPrOnThePublishedData) {
  const auto data = ips::load_calib_csv(ips::test::train40_path());
  for (const auto& set : data.cameras) {
    auto pr = ips::make_mapper("pr");
    auto rtpr = ips::make_mapper("rt+pr");
    pr->fit(set.cam, set.world, {});
    rtpr->fit(set.cam, set.world, {});
    for (const auto& c : set.cam) EXPECT_LT((pr->predict(c) - rtpr->predict(c)).norm(), 1e-9) << set.camera;
    EXPECT_LT((pr->predict({0.1, 0.2, 2.0}) - rtpr->predict({0.1, 0.2, 2.0})).norm(), 1e-9);
  }
}

TEST(Registry, UnknownNameListsTheKnownOnes) {
  try {
    ips::make_mapper("rt+foo");
    FAIL();
  } catch (const ips::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "unknown mapping method 'rt+foo' (known: rt, pr, rt+pr, ann, rt+ann, ki, rt+ki, kr, "
              "rt+kr, plane, auto)");
  }
  for (const auto& name : ips::mapper_names()) EXPECT_EQ(ips::make_mapper(name)->method(), name);
}

}  // namespace
