#include "ips/mapping/cross_validation.h"

#include <gtest/gtest.h>

#include "ips/core/error.h"
#include "test_util.h"

namespace {

TEST(CrossValidation, FoldsAreInterleaved) {
  EXPECT_EQ(ips::fold_assignment(7, 3), (std::vector<int>{0, 1, 2, 0, 1, 2, 0}));
  EXPECT_EQ(ips::fold_assignment(3, 10), (std::vector<int>{0, 1, 2}));  // k >= n: leave-one-out
  EXPECT_THROW(ips::fold_assignment(5, 1), ips::InputError);
}

// Data that is exactly a rigid transform: every left-out point is predicted exactly.
TEST(CrossValidation, ExactDataHasZeroError) {
  const auto cam = ips::test::random_points(12, {-1, -1, 1.9}, {1, 1, 2.2}, 1);
  std::vector<Eigen::Vector3d> world;
  for (const auto& c : cam) world.push_back(c + Eigen::Vector3d(1, 2, 3));
  const auto loo = ips::cross_validate("rt", cam, world, 0, {});
  EXPECT_EQ(loo.n, 12u);
  EXPECT_LT(loo.err3d.max, 1e-12);
  const auto k4 = ips::cross_validate("rt", cam, world, 4, {});
  EXPECT_LT(k4.err3d.max, 1e-12);
}

TEST(CrossValidation, FoldTooSmallForTheMethodIsAnInputError) {
  const auto cam = ips::test::random_points(12, {-1, -1, 1.9}, {1, 1, 2.2}, 1);
  try {
    ips::cross_validate("pr", cam, cam, 3, {});  // training folds of 8 < 10 pairs
    FAIL();
  } catch (const ips::InputError& e) {
    EXPECT_EQ(std::string(e.what()), "method 'pr' needs at least 10 training pairs per fold, a fold has 8");
  }
}

}  // namespace
