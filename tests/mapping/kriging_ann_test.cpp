// ki, kr and ann against smooth synthetic functions with known values.
#include <gtest/gtest.h>

#include <cmath>

#include "ips/mapping/mapper.h"

#include <nlohmann/json.hpp>
#include "test_util.h"

namespace {

using Points = std::vector<Eigen::Vector3d>;

// A smooth, mildly nonlinear camera->world map of the size of a lab floor (metres).
Eigen::Vector3d smooth(const Eigen::Vector3d& c) {
  return {2.4 + c.x() + 0.05 * std::sin(1.3 * c.y()) + 0.02 * c.x() * c.x(), 2.1 - c.y() + 0.04 * std::cos(0.9 * c.x()),
          2.2 - c.z() + 0.03 * std::sin(c.x() + c.y())};
}

Points cam_points(std::size_t n, std::uint32_t seed) {
  return ips::test::random_points(n, {-2, -1.5, 1.9}, {2, 1.5, 2.2}, seed);
}

TEST(Kriging, KiInterpolatesItsTrainingPoints) {
  const Points cam = cam_points(40, 21);
  Points world;
  for (const auto& c : cam) world.push_back(smooth(c));
  auto ki = ips::make_mapper("ki");
  ki->fit(cam, world, {});
  for (std::size_t i = 0; i < cam.size(); ++i) EXPECT_LT((ki->predict(cam[i]) - world[i]).norm(), 1e-6);
  // And it generalises: new points inside the hull within a few mm of the truth.
  for (const auto& q : ips::test::random_points(20, {-1.5, -1, 1.95}, {1.5, 1, 2.15}, 22))
    EXPECT_LT((ki->predict(q) - smooth(q)).norm(), 0.01);
}

TEST(Kriging, KrDoesNotInterpolateNoisyPointsAndSmoothsThem) {
  const Points cam = cam_points(40, 31);
  const double sigma = 0.005;
  const auto noise = ips::test::gaussian_noise(3 * cam.size(), sigma, 32);
  Points world, clean;
  for (std::size_t i = 0; i < cam.size(); ++i) {
    clean.push_back(smooth(cam[i]));
    world.push_back(clean.back() + Eigen::Vector3d(noise[3 * i], noise[3 * i + 1], noise[3 * i + 2]));
  }
  auto kr = ips::make_mapper("kr");
  auto ki = ips::make_mapper("ki");
  kr->fit(cam, world, {});
  ki->fit(cam, world, {});
  double kr_to_noisy = 0.0, kr_to_clean = 0.0, ki_to_noisy = 0.0;
  for (std::size_t i = 0; i < cam.size(); ++i) {
    kr_to_noisy += (kr->predict(cam[i]) - world[i]).squaredNorm();
    kr_to_clean += (kr->predict(cam[i]) - clean[i]).squaredNorm();
    ki_to_noisy += (ki->predict(cam[i]) - world[i]).squaredNorm();
  }
  const double n = 3.0 * static_cast<double>(cam.size());
  EXPECT_LT(std::sqrt(ki_to_noisy / n), 1e-6);         // ki goes through the noise
  EXPECT_GT(std::sqrt(kr_to_noisy / n), 0.3 * sigma);  // kr does not...
  EXPECT_LT(std::sqrt(kr_to_clean / n), sigma);        // ...and lands closer to the truth
}

TEST(Ann, FitsASmoothFunction) {
  const Points cam = cam_points(60, 41);
  Points world;
  for (const auto& c : cam) world.push_back(smooth(c));
  auto ann = ips::make_mapper("ann");
  ips::FitOptions options;
  options.seed = 3;
  ann->fit(cam, world, options);
  double worst = 0.0;
  for (const auto& q : ips::test::random_points(30, {-1.5, -1, 1.95}, {1.5, 1, 2.15}, 42))
    worst = std::max(worst, (ann->predict(q) - smooth(q)).norm());
  EXPECT_LT(worst, 0.01);  // 1 cm over a 4 m x 3 m area
}

TEST(Ann, IsDeterministicForASeed) {
  const Points cam = cam_points(20, 51);
  Points world;
  for (const auto& c : cam) world.push_back(smooth(c));
  ips::FitOptions options;
  options.seed = 9;
  auto a = ips::make_mapper("ann");
  auto b = ips::make_mapper("ann");
  a->fit(cam, world, options);
  b->fit(cam, world, options);
  EXPECT_EQ(a->to_json(), b->to_json());
  options.seed = 10;
  auto c = ips::make_mapper("ann");
  c->fit(cam, world, options);
  EXPECT_NE(a->to_json(), c->to_json());
}

}  // namespace
