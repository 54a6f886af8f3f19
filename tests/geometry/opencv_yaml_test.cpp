// CameraModel::load reads OpenCV's YAML calibration files with yaml-cpp (geometry/opencv_yaml.h),
// never with OpenCV's own YAML parser (which hangs or aborts on some malformed files). The truth
// here is OpenCV itself: files written by cv::FileStorage, and the numbers cv::FileStorage reads
// back from them (on files OpenCV wrote, its reader is safe).
#include "ips/geometry/camera_model.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "ips/core/error.h"
#include "load_error.h"

namespace fs = std::filesystem;

namespace {

const fs::path kSource = IPS_SOURCE_DIR;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "ips_opencv_yaml_test";
  fs::create_directories(dir);
  return dir / name;
}

fs::path write_text(const std::string& name, const std::string& text) {
  const fs::path p = scratch(name);
  std::ofstream(p) << text;
  return p;
}

std::string input_error(const fs::path& p) { return ips::test::camera_model_load_error(p); }

// What OpenCV's reader makes of a file OpenCV wrote: K and D as doubles.
void opencv_reads(const fs::path& p, const char* k_key, const char* d_key, cv::Mat& K, cv::Mat& D) {
  cv::FileStorage in(p.string(), cv::FileStorage::READ);
  ASSERT_TRUE(in.isOpened()) << p;
  in[k_key] >> K;
  in[d_key] >> D;
  K.convertTo(K, CV_64F);
  D.convertTo(D, CV_64F);
}

void expect_same_numbers(const ips::CameraModel& cam, const cv::Mat& K, const cv::Mat& D) {
  ASSERT_EQ(K.total(), 9u);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(cam.K().val[i], K.at<double>(i)) << "K[" << i << "]";
  ASSERT_GE(cam.D().size(), D.total());
  for (int i = 0; i < static_cast<int>(D.total()); ++i)
    EXPECT_EQ(cam.D()[static_cast<std::size_t>(i)], D.at<double>(i)) << "D[" << i << "]";
}

// A calibration file as OpenCV's calibration sample writes it (extra keys, a 2-channel matrix,
// strings), with K and D of the given depth.
fs::path write_like_calibration_sample(const std::string& name, const ips::CameraModel& cam, int depth, bool fisheye) {
  const fs::path p = scratch(name);
  cv::FileStorage out(p.string(), cv::FileStorage::WRITE);
  out << "calibration_time"
      << "Mon Nov 23 22:00:00 2026";
  out << "nr_of_frames" << 25 << "image_width" << cam.size().width << "image_height" << cam.size().height;
  out << "board_width" << 9 << "board_height" << 6 << "square_size" << 0.025;
  out << "fix_aspect_ratio" << 1.0 << "flags" << 0 << "fisheye_model" << (fisheye ? 1 : 0);
  cv::Mat K(cam.K()), D(cam.D());
  K.convertTo(K, depth);
  D.convertTo(D, depth);
  out << "camera_matrix" << K << "distortion_coefficients" << D;
  out << "avg_reprojection_error" << 0.41;
  out << "per_view_reprojection_errors" << cv::Mat(cv::Mat_<float>({0.4f, 0.39f, 0.45f}));
  out << "extrinsic_parameters" << cv::Mat(cv::Mat::ones(3, 6, CV_64F) * 0.1);
  out << "image_points" << cv::Mat(3, 54, CV_32FC2, cv::Scalar(12.5f, 7.25f));
  return p;
}

// Every ipsd-form intrinsics file the repository ships, rewritten by OpenCV's writer (doubles at
// full precision, and floats): CameraModel::load gives exactly the numbers OpenCV's reader gives.
TEST(OpenCvYaml, FilesOpenCVWroteReadAsOpenCVReadsThem) {
  const fs::path files[] = {
      kSource / "calib_data/ou2023/intrinsics_red.yaml",      kSource / "calib_data/ou2023/intrinsics_white.yaml",
      kSource / "calib_data/ou2023/intrinsics_black.yaml",    kSource / "config/scenes/lenses/pinhole_wide.yaml",
      kSource / "tests/replay/data/intrinsics_red_half.yaml", kSource / "tests/replay/data/intrinsics_white_half.yaml"};
  for (const fs::path& src : files) {
    const ips::CameraModel cam = ips::CameraModel::load(src);
    const bool fisheye = cam.kind() == ips::CameraModel::Kind::kFisheye;
    for (const int depth : {CV_64F, CV_32F}) {
      SCOPED_TRACE(src.filename().string() + (depth == CV_64F ? " as dt d" : " as dt f"));
      const fs::path p = write_like_calibration_sample(src.stem().string() + (depth == CV_64F ? "_d.yml" : "_f.yml"),
                                                       cam, depth, fisheye);
      cv::Mat K, D;
      opencv_reads(p, "camera_matrix", "distortion_coefficients", K, D);
      const ips::CameraModel back = ips::CameraModel::load(p);
      EXPECT_EQ(back.kind(), cam.kind());
      EXPECT_EQ(back.size(), cam.size());
      expect_same_numbers(back, K, D);
      if (depth == CV_64F) expect_same_numbers(back, cv::Mat(cam.K()), cv::Mat(cam.D()));
    }
  }
}

// The OpenCV-form seeds of fuzz_intrinsics (hand-written in OpenCV's layout): same numbers as
// OpenCV's reader.
TEST(OpenCvYaml, RepositoryOpenCVYamlFilesMatchOpenCVsReader) {
  int n = 0;
  for (const auto& entry : fs::directory_iterator(kSource / "fuzz/corpus/intrinsics")) {
    std::ifstream in(entry.path());
    std::string first;
    std::getline(in, first);
    if (first.rfind("%YAML:", 0) != 0) continue;
    SCOPED_TRACE(entry.path().string());
    cv::Mat K, D;
    opencv_reads(entry.path(), "camera_matrix", "distortion_coefficients", K, D);
    expect_same_numbers(ips::CameraModel::load(entry.path()), K, D);
    ++n;
  }
  EXPECT_GE(n, 1);
}

// fuzz_intrinsics' timeout after the old guard: yaml-cpp's LoadAll returned null documents
// forever on a document starting with ','. Now a prompt error naming the file and line.
TEST(OpenCvYaml, TheOldGuardsTimeoutIsAPromptInputError) {
  const fs::path p = kSource / "tests/fuzz/intrinsics/opencv_timeout_after_guard.yaml";
  const std::string msg = input_error(p);
  EXPECT_NE(msg.find("opencv_timeout_after_guard.yaml:2:"), std::string::npos) << msg;
  // The same trap in a file's second document.
  const std::string second = input_error(write_text("comma_doc.yml", "%YAML:1.0\n---\na: 1\n---\n, 2\n"));
  EXPECT_NE(second.find("comma_doc.yml:4: a second YAML document"), std::string::npos) << second;
}

TEST(OpenCvYaml, BadFilesNameFileLineAndKey) {
  const std::string head = "%YAML:1.0\n---\nimage_width: 1280\nimage_height: 720\n";
  const std::string k =
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 700., 0., 640., 0., 700., 360., 0., 0., 1. ]\n";
  const std::string d =
      "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
      "   data: [ -0.1, 0.01, 0., 0., 0.002 ]\n";
  auto with = [](std::string text, const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  struct Case {
    const char* name;
    std::string text;
    const char* says;
  } cases[] = {
      {"shape.yml", head + with(k, "rows: 3", "rows: 4"),
       "shape.yml:9: key 'camera_matrix': rows x cols = 12 but data has 9"},
      {"huge.yml", head + with(k, "rows: 3", "rows: 30000"), "huge.yml:6: key 'camera_matrix': 30000 x 3 is not"},
      {"rows_text.yml", head + with(k, "rows: 3", "rows: three"),
       "rows_text.yml:6: key 'camera_matrix.rows': not a number"},
      {"two_channel.yml", head + with(k, "dt: d", "dt: 2f"), "two_channel.yml:8: key 'camera_matrix.dt': '2f'"},
      {"nan.yml", head + with(k, "700.,", ".Nan,"), "nan.yml:9: key 'camera_matrix.data': non-finite"},
      {"word.yml", head + k + with(d, "0.01", "x"), "word.yml:14: key 'distortion_coefficients.data': not a number"},
      {"float_range.yml", head + with(k, "640.", "1e300") + d,
       "float_range.yml:9: key 'camera_matrix.data': out of range for dt f"},
      {"no_data.yml", head + with(k, "   data: [ 700., 0., 640., 0., 700., 360., 0., 0., 1. ]\n", ""),
       "no_data.yml:5: key 'camera_matrix': missing 'data'"},
      {"nd.yml", head + with(k, "!!opencv-matrix", "!!opencv-nd-matrix"),
       "nd.yml:5: key 'camera_matrix': expected an !!opencv-matrix"},
      {"list.yml", head + "camera_matrix: [ 700., 0., 640., 0., 700., 360., 0., 0., 1. ]\n" + d,
       "list.yml:5: key 'camera_matrix': expected an !!opencv-matrix"},
      {"no_k.yml", head + d, "no_k.yml: missing key 'camera_matrix'"},
      {"width.yml", with(head, "1280", "1280.5") + k + d, "width.yml:3: key 'image_width': not an integer"},
      {"neg.yml", with(head, "720", "-720") + k + d,
       "neg.yml: key 'image_width'/'image_height': image size must be positive"},
      {"fx.yml", head + with(k, "700.,", "-700.,") + d, "fx.yml: key 'camera_matrix': focal lengths"},
      {"directive.yml", "%YAML:2.0\n" + head.substr(10) + k + d, "directive.yml:1: expected the directive %YAML:1.0"},
      {"syntax.yml", head + "camera_matrix: [ 1, 2\n", "syntax.yml:"},
      {"scalar.yml", "%YAML:1.0\n---\njust text\n", "scalar.yml: expected a YAML mapping"},
      {"model.yml", head + "model: [fisheye]\n" + k + d, "model.yml:5: key 'model': not a string"},
  };
  // float_range needs dt f.
  cases[6].text = with(cases[6].text, "dt: d", "dt: f");
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string msg = input_error(write_text(c.name, c.text));
    EXPECT_NE(msg.find(c.says), std::string::npos) << msg;
  }
}

// OpenCV's form is also recognised in a plain YAML file without the directive (keys
// camera_matrix / mtx): read the same way, not by OpenCV.
TEST(OpenCvYaml, WithoutTheDirective) {
  const auto cam = ips::CameraModel::load(
      write_text("plain.yaml",
                 "img_width: 1920\nimg_height: 1080\nfisheye_model: 1\n"
                 "mtx: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                 "   data: [ 1100., 0., 960., 0., 1100., 540., 0., 0., 1. ]\n"
                 "dist: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: d\n   data: [ -0.1, 0.01, -0.02, 0.01 ]\n"));
  EXPECT_EQ(cam.kind(), ips::CameraModel::Kind::kFisheye);
  EXPECT_EQ(cam.size(), cv::Size(1920, 1080));
  EXPECT_EQ(cam.D()[2], -0.02);
}

}  // namespace
