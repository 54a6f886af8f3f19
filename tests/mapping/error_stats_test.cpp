#include "ips/mapping/error_stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

namespace {

// Offsets chosen so that every error is exact: (0.03, 0.04, 0) -> 3D 0.05, 2D 0.05;
// (0, 0, 0.02) -> 3D 0.02, 2D 0; (0.06, 0.08, 0) -> 3D 0.10, 2D 0.10.
TEST(ErrorStats, HandComputedTriple) {
  const std::vector<Eigen::Vector3d> truth = {{1, 2, 0}, {0, 0, 0}, {-1, 3, 0.2}};
  const std::vector<Eigen::Vector3d> pred = {{1.03, 2.04, 0}, {0, 0, 0.02}, {-0.94, 3.08, 0.2}};
  const ips::CameraErrors e = ips::compare_points(pred, truth);
  EXPECT_EQ(e.n, 3u);
  // 3D: mean (0.05 + 0.02 + 0.10) / 3 = 0.0566667; sample std = sqrt(0.00326667 / 2) = 0.0404145.
  EXPECT_NEAR(e.err3d.mean, 0.17 / 3.0, 1e-12);
  EXPECT_NEAR(e.err3d.min, 0.02, 1e-12);
  EXPECT_NEAR(e.err3d.max, 0.10, 1e-12);
  EXPECT_NEAR(e.err3d.std, 0.0404145188432738, 1e-12);
  // 2D: 0.05, 0, 0.10 -> mean 0.05, std = sqrt((0 + 0.0025 + 0.0025) / 2) = 0.05.
  EXPECT_NEAR(e.err2d.mean, 0.05, 1e-12);
  EXPECT_NEAR(e.err2d.min, 0.0, 1e-12);
  EXPECT_NEAR(e.err2d.max, 0.10, 1e-12);
  EXPECT_NEAR(e.err2d.std, 0.05, 1e-12);

  const nlohmann::json j = ips::errors_to_json(e);
  EXPECT_EQ(j["n"], 3);
  EXPECT_NEAR(j["err3d"]["std"].get<double>(), 0.0404145188432738, 1e-12);
  EXPECT_EQ(j["err2d"].size(), 4u);
}

TEST(ErrorStats, SingleErrorHasNoSampleStd) {
  const std::vector<double> one = {0.3};
  const auto s = ips::summarize_errors(one);
  EXPECT_EQ(s.mean, 0.3);
  EXPECT_TRUE(std::isnan(s.std));
  const std::vector<Eigen::Vector3d> a = {{0, 0, 0}}, b = {{0, 0, 1}};
  EXPECT_TRUE(ips::errors_to_json(ips::compare_points(a, b))["err3d"]["std"].is_null());
}

}  // namespace
