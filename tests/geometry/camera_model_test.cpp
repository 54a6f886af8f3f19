#include "ips/geometry/camera_model.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "ips/core/error.h"
#include "load_error.h"

namespace fs = std::filesystem;

namespace {

const fs::path kData = IPS_TEST_DATA_DIR;

fs::path write_temp(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / "ips_camera_model_test";
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p;
}

std::string expect_input_error(const fs::path& p) { return ips::test::camera_model_load_error(p); }

TEST(CameraModel, LoadsShippedIntrinsics) {
  const auto cam = ips::CameraModel::load(kData / "ou2023/intrinsics_red.yaml");
  EXPECT_EQ(cam.kind(), ips::CameraModel::Kind::kFisheye);
  EXPECT_EQ(cam.size(), cv::Size(1920, 1080));
  EXPECT_DOUBLE_EQ(cam.K()(0, 0), 1151.6413720243977);
  EXPECT_DOUBLE_EQ(cam.K()(1, 2), 504.28136395041639);
  ASSERT_EQ(cam.D().size(), 4u);
  EXPECT_DOUBLE_EQ(cam.D()[3], 0.016798029858339236);
}

// Hand-computed fisheye projection: u = 0.5, v = 0 -> theta = atan(0.5).
TEST(CameraModel, FisheyeProjectMatchesFormulaAndOpenCV) {
  const auto cam = ips::CameraModel::load(kData / "ou2023/intrinsics_red.yaml");
  const double th = std::atan(0.5);
  const auto& D = cam.D();
  const double thd =
      th * (1 + D[0] * std::pow(th, 2) + D[1] * std::pow(th, 4) + D[2] * std::pow(th, 6) + D[3] * std::pow(th, 8));
  const ips::Point2 p = cam.project({0.5, 0.0});
  EXPECT_NEAR(p.x, cam.K()(0, 0) * thd / 0.5 * 0.5 + cam.K()(0, 2), 1e-9);
  EXPECT_NEAR(p.y, cam.K()(1, 2), 1e-9);

  std::vector<cv::Point3d> obj{{0.3, -0.7, 1.0}, {-1.2, 0.4, 1.0}, {0.01, 0.02, 1.0}};
  std::vector<cv::Point2d> img;
  cv::fisheye::projectPoints(obj, img, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(cam.K()), cv::Mat(cam.D()));
  for (std::size_t i = 0; i < obj.size(); ++i) {
    const ips::Point2 q = cam.project({obj[i].x, obj[i].y});
    EXPECT_NEAR(q.x, img[i].x, 1e-8);
    EXPECT_NEAR(q.y, img[i].y, 1e-8);
  }
}

// Every pixel the model maps to a ray must come back exactly; pixels without a ray may only
// be the extreme corners (where a fitted fisheye polynomial turns back).
void expect_round_trip_over_image(const ips::CameraModel& cam) {
  double worst = 0.0;
  int no_ray = 0;
  int total = 0;
  for (int y = 0; y <= cam.size().height; y += 20) {
    for (int x = 0; x <= cam.size().width; x += 20) {
      const ips::Point2 px{x - 0.5, y - 0.5};
      const ips::Point2 n = cam.undistort(px);
      ++total;
      if (std::isnan(n.x)) {
        ++no_ray;
        const double dx = std::min(px.x, cam.size().width - px.x);
        const double dy = std::min(px.y, cam.size().height - px.y);
        EXPECT_LT(std::hypot(dx, dy), 200.0) << "no ray at " << px.x << "," << px.y;
        continue;
      }
      const ips::Point2 back = cam.project(n);
      worst = std::max(worst, std::hypot(back.x - px.x, back.y - px.y));
    }
  }
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(no_ray, total / 100);
}

TEST(CameraModel, FisheyeRoundTripExactOverWholeImage) {
  for (const char* name : {"red", "white", "black"}) {
    SCOPED_TRACE(name);
    expect_round_trip_over_image(ips::CameraModel::load(kData / (std::string("ou2023/intrinsics_") + name + ".yaml")));
  }
}

TEST(CameraModel, FisheyeUndistortAgreesWithOpenCVInTheCentre) {
  const auto cam = ips::CameraModel::load(kData / "ou2023/intrinsics_red.yaml");
  std::vector<cv::Point2d> px{{900.0, 500.0}, {1300.0, 800.0}, {400.0, 200.0}}, out;
  cv::fisheye::undistortPoints(px, out, cv::Mat(cam.K()), cv::Mat(cam.D()));
  for (std::size_t i = 0; i < px.size(); ++i) {
    const ips::Point2 n = cam.undistort({px[i].x, px[i].y});
    EXPECT_NEAR(n.x, out[i].x, 1e-5);
    EXPECT_NEAR(n.y, out[i].y, 1e-5);
  }
}

TEST(CameraModel, PinholeRoundTripAndOpenCVProjection) {
  const cv::Matx33d K(1000, 0, 960, 0, 1005, 540, 0, 0, 1);
  for (const std::vector<double>& D :
       {std::vector<double>{-0.2, 0.05, 0.001, -0.0005}, std::vector<double>{-0.25, 0.08, 0.0005, 0.0002, -0.01},
        std::vector<double>{-0.1, 0.02, 0.0003, 0.0001, 0.001, 0.05, -0.01, 0.002}}) {
    SCOPED_TRACE(D.size());
    const ips::CameraModel cam(ips::CameraModel::Kind::kPinhole, {1920, 1080}, K, D);
    std::vector<cv::Point3d> obj{{0.3, -0.2, 1.0}, {-0.6, 0.4, 1.0}};
    std::vector<cv::Point2d> img;
    cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(K), cv::Mat(D), img);
    for (std::size_t i = 0; i < obj.size(); ++i) {
      const ips::Point2 q = cam.project({obj[i].x, obj[i].y});
      EXPECT_NEAR(q.x, img[i].x, 1e-8);
      EXPECT_NEAR(q.y, img[i].y, 1e-8);
    }
    expect_round_trip_over_image(cam);
  }
}

TEST(CameraModel, ReadsOpenCVFileStorage) {
  const auto p = write_temp("cv_calib.yml",
                            "%YAML:1.0\n---\nimage_width: 1280\nimage_height: 720\n"
                            "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                            "   data: [ 700., 0., 640., 0., 701., 360., 0., 0., 1. ]\n"
                            "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
                            "   data: [ -0.1, 0.01, 0., 0., 0.002 ]\n");
  const auto cam = ips::CameraModel::load(p);
  EXPECT_EQ(cam.kind(), ips::CameraModel::Kind::kPinhole);
  EXPECT_EQ(cam.size(), cv::Size(1280, 720));
  EXPECT_DOUBLE_EQ(cam.K()(1, 1), 701.0);
  EXPECT_DOUBLE_EQ(cam.D()[4], 0.002);

  const auto q = write_temp("cv_fisheye.yml",
                            "%YAML:1.0\n---\nimg_width: 1920\nimg_height: 1080\nfisheye_model: 1\n"
                            "mtx: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                            "   data: [ 1100., 0., 960., 0., 1100., 540., 0., 0., 1. ]\n"
                            "dist: !!opencv-matrix\n   rows: 4\n   cols: 1\n   dt: d\n"
                            "   data: [ -0.1, 0.01, -0.02, 0.01 ]\n");
  const auto fish = ips::CameraModel::load(q);
  EXPECT_EQ(fish.kind(), ips::CameraModel::Kind::kFisheye);
  EXPECT_EQ(fish.size().width, 1920);

  const auto bad = write_temp("cv_bad.yml",
                              "%YAML:1.0\n---\nimage_width: 1280\nimage_height: 720\n"
                              "camera_matrix: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n"
                              "   data: [ 700., 0., 640., 0. ]\n"
                              "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
                              "   data: [ -0.1, 0.01, 0., 0., 0.002 ]\n");
  EXPECT_NE(expect_input_error(bad).find("camera_matrix"), std::string::npos);
}

TEST(CameraModel, BadFilesNameTheKey) {
  const std::string good_k = "K: [1000, 0, 960, 0, 1000, 540, 0, 0, 1]\n";
  struct Case {
    const char* name;
    std::string text;
    const char* key;
  } cases[] = {
      {"no_model.yaml", "image_width: 1920\nimage_height: 1080\n" + good_k + "D: [0,0,0,0]\n", "model"},
      {"bad_model.yaml", "model: fish\nimage_width: 1920\nimage_height: 1080\n" + good_k + "D: [0,0,0,0]\n", "model"},
      {"short_k.yaml", "model: fisheye\nimage_width: 1920\nimage_height: 1080\nK: [1,2,3]\nD: [0,0,0,0]\n", "'K'"},
      {"nan_k.yaml",
       "model: fisheye\nimage_width: 1920\nimage_height: 1080\nK: [.nan, 0, 960, 0, 1000, 540, 0, "
       "0, 1]\nD: [0,0,0,0]\n",
       "'K'"},
      {"short_d.yaml", "model: fisheye\nimage_width: 1920\nimage_height: 1080\n" + good_k + "D: [0,0,0]\n", "'D'"},
      {"pinhole_d.yaml", "model: pinhole\nimage_width: 1920\nimage_height: 1080\n" + good_k + "D: [0,0,0,0,0,0]\n",
       "'D'"},
      {"text_d.yaml", "model: fisheye\nimage_width: 1920\nimage_height: 1080\n" + good_k + "D: [a,0,0,0]\n", "'D'"},
      {"no_width.yaml", "model: fisheye\nimage_height: 1080\n" + good_k + "D: [0,0,0,0]\n", "image_width"},
      {"neg_width.yaml", "model: fisheye\nimage_width: -5\nimage_height: 1080\n" + good_k + "D: [0,0,0,0]\n",
       "image_width"},
      {"broken.yaml", "model: [fisheye\n", "YAML"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string msg = expect_input_error(write_temp(c.name, c.text));
    EXPECT_NE(msg.find(c.key), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.name), std::string::npos) << msg;
  }
  EXPECT_NE(expect_input_error("/nonexistent/cam.yaml").find("/nonexistent/cam.yaml"), std::string::npos);
}

TEST(CameraModel, ReadsOpenCVXml) {
  const auto p = write_temp(
      "cv_calib.xml",
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n"
      "<image_height>480</image_height>\n<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols>"
      "<dt>d</dt>\n<data>500. 0. 320. 0. 500. 240. 0. 0. 1.</data></camera_matrix>\n"
      "<distortion_coefficients type_id=\"opencv-matrix\"><rows>5</rows><cols>1</cols><dt>d</dt>\n"
      "<data>0.1 -0.05 0. 0. 0.01</data></distortion_coefficients>\n</opencv_storage>\n");
  const auto m = ips::CameraModel::load(p);
  EXPECT_EQ(m.kind(), ips::CameraModel::Kind::kPinhole);
  EXPECT_EQ(m.size().width, 640);
  EXPECT_DOUBLE_EQ(m.K()(0, 2), 320.0);
  ASSERT_GE(m.D().size(), 5u);  // pinhole D is held padded to OpenCV's 8 terms
  EXPECT_DOUBLE_EQ(m.D()[4], 0.01);
}

// Found by fuzz/fuzz_intrinsics (regression inputs in tests/fuzz/intrinsics/): OpenCV files that
// FileStorage opens but cannot navigate threw cv::Exception past the loader (the daemon exited
// 1 with OpenCV's internal message), an image size beyond int was converted undefinedly, and a
// matrix's rows/cols were allocated before being checked against its data.
TEST(CameraModel, OpenCVFilesOpenCVCannotNavigateAreInputErrors) {
  const std::string matrices =
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 700., 0., 640., 0., 700., 360., 0., 0., 1. ]\n"
      "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
      "   data: [ -0.1, 0.01, 0., 0., 0.002 ]\n";
  struct Case {
    const char* name;
    std::string text;
    const char* says;
  } cases[] = {
      {"cv_sequence.yml", "%YAML:1.0caAe\n%Y---\n-", "cv_sequence.yml:1: expected the directive %YAML:1.0"},
      {"cv_huge_width.yml", "%YAML:1.0\n---\nimage_width: 1e300\nimage_height: 720\n" + matrices, "image_width"},
      {"cv_inf_height.yml", "%YAML:1.0\n---\nimage_width: 1280\nimage_height: -.Inf\n" + matrices, "image_height"},
      // OpenCV 4.6's reader calls std::terminate on this (a nested key starting with ':'); yaml-cpp
      // reads it (geometry/opencv_yaml.h).
      {"cv_colon_key.yml", "%YAML:1.0\n---\nm:\n   rows: 3\n   :cols: 3\n",
       "cv_colon_key.yml: missing key 'camera_matrix'"},
      // ... and loops forever on this one (a second '%' line).
      {"cv_second_directive.yml", "%YAML:1.0\nimage_width: 640\n%Y---\n   3\n   cols: 3\n",
       "cv_second_directive.yml:5: YAML error"},
      // OpenCV would allocate 30000 x 30000 doubles (7 GB) before noticing the data is short.
      {"cv_rows_typo.yml",
       "%YAML:1.0\n---\nimage_width: 1280\nimage_height: 720\ncamera_matrix: !!opencv-matrix\n"
       "   rows: 30000\n   cols: 30000\n   dt: d\n   data: [ 700., 0., 640., 0., 700., 360., 0., 0., 1. ]\n",
       "camera_matrix"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string msg = expect_input_error(write_temp(c.name, c.text));
    EXPECT_NE(msg.find(c.says), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.name), std::string::npos) << msg;
  }
}

// OpenCV 4.6's YAML reader loops forever on this fuzz_intrinsics find (two YAML documents of
// garbage after the directive); OpenCV no longer reads YAML files at all.
TEST(CameraModel, GarbageThatHangsOpenCVsYamlReaderIsAnInputError) {
  const std::string path = std::string(IPS_SOURCE_DIR) + "/tests/fuzz/intrinsics/opencv_yaml_reader_hangs.yaml";
  const std::string msg = expect_input_error(path);
  EXPECT_NE(msg.find("opencv_yaml_reader_hangs.yaml:1: expected the directive %YAML:1.0"), std::string::npos) << msg;
}

}  // namespace
