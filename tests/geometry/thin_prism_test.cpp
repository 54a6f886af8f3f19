// The pinhole model with OpenCV's thin-prism terms (12 coefficients, what
// `ips calibrate --model pinhole --thin-prism` writes) against cv::projectPoints.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "ips/geometry/camera_model.h"

TEST(ThinPrism, ProjectMatchesOpenCVAndUndistortInverts) {
  const cv::Matx33d K(620.0, 0.0, 641.3, 0.0, 621.5, 358.7, 0.0, 0.0, 1.0);
  const std::vector<double> D{-0.05, 0.01, 0.0004, -0.0003, 0.0, 0.1, 0.0, 0.0, 0.002, -0.0005, -0.0015, 0.0004};
  const ips::CameraModel m(ips::CameraModel::Kind::kPinhole, {1280, 720}, K, D);
  ASSERT_EQ(m.D().size(), 12u);
  std::vector<cv::Point3d> rays;
  for (double x = -1.2; x <= 1.2; x += 0.1)
    for (double y = -0.6; y <= 0.6; y += 0.1) rays.emplace_back(x, y, 1.0);
  std::vector<cv::Point2d> px;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, px);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const ips::Point2 p = m.project({rays[i].x, rays[i].y});
    EXPECT_NEAR(p.x, px[i].x, 1e-9);
    EXPECT_NEAR(p.y, px[i].y, 1e-9);
    const ips::Point2 n = m.undistort(p);
    EXPECT_NEAR(n.x, rays[i].x, 1e-9);
    EXPECT_NEAR(n.y, rays[i].y, 1e-9);
  }
  // 12 is accepted, other counts are still refused.
  EXPECT_THROW(ips::CameraModel(ips::CameraModel::Kind::kPinhole, {1280, 720}, K, std::vector<double>(10, 0.0)),
               std::exception);
}
