#include "ips/sim/renderer.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/core/error.h"

namespace {

ips::sim::Scene base_scene() {
  auto s = ips::sim::Scene::load(std::filesystem::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml");
  s.markers.clear();
  return s;
}

TEST(Renderer, VignettingNoiseAndJpeg) {
  auto scene = base_scene();
  scene.render.noise_sigma = 3.0;
  const ips::sim::CameraRenderer r(scene, 0);
  cv::Mat a, b;
  r.render_markers({}, a, 1);
  r.render_markers({}, b, 2);
  ASSERT_EQ(a.size(), cv::Size(1920, 1080));
  // Vignetting: the image centre is brighter than the corners.
  const double centre = cv::mean(a(cv::Rect(860, 440, 200, 200)))[0];
  const double corner = cv::mean(a(cv::Rect(20, 20, 200, 200)))[0];
  EXPECT_GT(centre, corner + 15);
  // Noise: two frames differ by independent Gaussian noise of sigma 3 each.
  cv::Mat diff;
  cv::subtract(a, b, diff, cv::noArray(), CV_32F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff(cv::Rect(400, 300, 1000, 500)), mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 0.1);
  EXPECT_NEAR(stddev[0], 3.0 * std::sqrt(2.0), 0.3);
  // Deterministic for a given noise index.
  cv::Mat a2;
  r.render_markers({}, a2, 1);
  EXPECT_EQ(cv::norm(a, a2, cv::NORM_INF), 0.0);
  // JPEG round trip (grey and colour) stays close to the frame.
  ips::JpegDecoder dec;
  for (bool colour : {false, true}) {
    cv::Mat back;
    ASSERT_TRUE(dec.decode_gray(ips::sim::encode_jpeg(a, 90, colour), back));
    EXPECT_LT(cv::norm(a, back, cv::NORM_L1) / static_cast<double>(a.total()), 3.0);
  }
  EXPECT_THROW(ips::sim::encode_jpeg(a, 0, false), ips::InputError);
}

TEST(Renderer, MotionBlurSmearsAMovingMarker) {
  auto scene = base_scene();
  scene.render.noise_sigma = 0;
  ips::sim::SceneMarker m;
  m.id = 3;
  m.trajectory.kind = ips::sim::Trajectory::Kind::kLine;
  m.trajectory.points = {{1.5, 0.9}, {3.2, 0.9}};
  m.trajectory.speed = 1.0;
  scene.markers.push_back(m);
  cv::Mat sharp, blurred;
  {
    const ips::sim::CameraRenderer r(scene, 0);
    r.render(0.5, sharp, 0);
  }
  scene.render.exposure = 0.02;  // 2 cm of travel, ~11 px
  scene.render.blur_samples = 9;
  {
    const ips::sim::CameraRenderer r(scene, 0);
    r.render(0.5, blurred, 0);
  }
  // Mid-grey pixels (neither black ink nor white paper) around the marker: few when sharp.
  auto mid_grey = [](const cv::Mat& img, const ips::sim::MarkerTruth& t) {
    double x0 = 1e9, y0 = 1e9, x1 = 0, y1 = 0;
    for (const auto& c : t.corners_px) {
      x0 = std::min(x0, c.x), y0 = std::min(y0, c.y), x1 = std::max(x1, c.x), y1 = std::max(y1, c.y);
    }
    const cv::Mat roi = img(cv::Rect(cv::Point(static_cast<int>(x0), static_cast<int>(y0)),
                                     cv::Point(static_cast<int>(x1), static_cast<int>(y1))));
    cv::Mat m1;
    cv::inRange(roi, 70, 150, m1);
    return cv::countNonZero(m1);
  };
  const ips::sim::CameraRenderer r(scene, 0);
  const auto truth = r.truth(0.5)[0];
  ASSERT_TRUE(truth.visible);
  EXPECT_GT(mid_grey(blurred, truth), 3 * mid_grey(sharp, truth) + 100);
}

TEST(Renderer, TruthOfAMarkerStraightBelowTheCamera) {
  const auto scene = base_scene();
  const ips::sim::CameraRenderer r(scene, 0);
  const auto& cam = r.camera();
  ips::sim::SceneMarker m;
  m.length = 0.2;
  // Directly under the optical centre at height 0.1: the formula truth has xc, yc ~ 0 and
  // zc ~ the distance along the (slightly tilted) optical axis.
  const Eigen::Vector3d below = cam.camera_to_world({0, 0, cam.position.z() - 0.1});
  const auto t = r.truth_of(m, {below.x(), below.y(), 0.1, 0.0});
  ASSERT_TRUE(t.visible);
  EXPECT_NEAR(t.centre_cam.x(), 0.0, 1e-3);
  EXPECT_NEAR(t.centre_cam.y(), 0.0, 1e-3);
  EXPECT_NEAR(t.formula.p_cam.z(), cam.position.z() - 0.1, 2e-3);
  // World yaw 0 = marker x along world x = image x: camera yaw ~ 0.
  EXPECT_NEAR(t.formula.yaw, 0.0, 0.02);
  // Behind the camera / far outside the view: not visible.
  EXPECT_FALSE(r.truth_of(m, {below.x() + 20.0, below.y(), 0.0, 0.0}).visible);
  EXPECT_THROW(ips::sim::marker_pattern("DICT_4X4_100", 100), ips::InputError);
}

}  // namespace
