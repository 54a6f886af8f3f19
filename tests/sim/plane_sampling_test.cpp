// The sub-pixel plane sampler shared by the floor and board renderers.
#include <gtest/gtest.h>

#include "../../src/sim/plane_sampling.h"

namespace {

TEST(PlaneSampling, InterpolatesBilinearlyInsideTheGrid) {
  cv::Mat ab(2, 2, CV_32FC2);
  ab.at<cv::Vec2f>(0, 0) = {0, 0};
  ab.at<cv::Vec2f>(0, 1) = {1, 0};
  ab.at<cv::Vec2f>(1, 0) = {0, 2};
  ab.at<cv::Vec2f>(1, 1) = {1, 2};
  const cv::Vec2d v = ips::sim::plane_coords_at(ab, 0.25, 0.75);  // a = x, b = 2 y by hand
  EXPECT_DOUBLE_EQ(v[0], 0.25);
  EXPECT_DOUBLE_EQ(v[1], 1.5);
}

// A marker box cut to one pixel by the image border gives a 1-row or 1-column grid: the sampler
// read outside it before (a heap-use-after-free under ASan in the daemon's synthetic cameras).
TEST(PlaneSampling, OneRowOrColumnGridsStayInside) {
  cv::Mat row(1, 3, CV_32FC2);
  for (int x = 0; x < 3; ++x) row.at<cv::Vec2f>(0, x) = {static_cast<float>(x), 7.0f};
  const cv::Vec2d r = ips::sim::plane_coords_at(row, 1.5, 0.3);
  EXPECT_DOUBLE_EQ(r[0], 1.5);
  EXPECT_DOUBLE_EQ(r[1], 7.0);
  cv::Mat one(1, 1, CV_32FC2, cv::Scalar(4.0, 5.0));
  const cv::Vec2d o = ips::sim::plane_coords_at(one, -0.25, 0.25);
  EXPECT_DOUBLE_EQ(o[0], 4.0);
  EXPECT_DOUBLE_EQ(o[1], 5.0);
}

}  // namespace
