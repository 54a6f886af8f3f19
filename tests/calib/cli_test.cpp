// `ips board`, `ips sim board-views` and `ips calibrate` (offline and live) run as a user would.
#include <unistd.h>
#include <array>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "ips/geometry/camera_model.h"

namespace fs = std::filesystem;

namespace {

const std::string kScene = std::string(IPS_CONFIG_DIR) + "/scenes/calib_lenses.yaml";
const std::string kBoard = "charuco:7x5:0.04:0.03:DICT_5X5_100";

using CmdResult = ips::test::CommandResult;
CmdResult run(const std::string& args, bool with_stderr = true) {
  return ips::test::run_program("ips", args, with_stderr);
}

std::string numbered(const char* pattern, int i) {
  char buf[64];
  std::snprintf(buf, sizeof buf, pattern, i);
  return buf;
}

// Per process: ctest runs these tests as parallel processes, each making its own views.
fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("ips_calib_cli_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Board views of the wide pinhole lens, made once for the tests below.
const fs::path& views_dir() {
  static const fs::path dir = [] {
    const fs::path d = temp_dir("views");
    const auto r = run("sim board-views --scene " + kScene + " --camera pinhole --views 14 --out " + d.string());
    EXPECT_EQ(r.status, 0) << r.out;
    return d;
  }();
  return dir;
}

}  // namespace

TEST(CalibCli, BoardWritesSvgAndPng) {
  const fs::path d = temp_dir("board");
  const auto r = run("board --board " + kBoard + " --out " + (d / "b.svg").string() + " --png " +
                     (d / "b.png").string() + " --dpi 200");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(fs::file_size(d / "b.svg") > 1000);
  // The PNG states its resolution: pHYs = 200 dpi = 7874 pixels per metre on both axes.
  std::ifstream pin(d / "b.png", std::ios::binary);
  std::stringstream pbuf;
  pbuf << pin.rdbuf();
  const std::string bytes = pbuf.str();
  const auto at = bytes.find("pHYs");
  ASSERT_NE(at, std::string::npos);
  const auto u32 = [&](std::size_t o) {
    return (std::uint32_t(std::uint8_t(bytes[o])) << 24) | (std::uint32_t(std::uint8_t(bytes[o + 1])) << 16) |
           (std::uint32_t(std::uint8_t(bytes[o + 2])) << 8) | std::uint32_t(std::uint8_t(bytes[o + 3]));
  };
  EXPECT_EQ(u32(at + 4), 7874u);
  EXPECT_EQ(u32(at + 8), 7874u);
  EXPECT_EQ(bytes[at + 12], 1);
  const cv::Mat png = cv::imread((d / "b.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(png.empty());
  // 280 mm board + 2 x 15 mm margin at 200 dpi.
  EXPECT_EQ(png.cols, static_cast<int>(std::lround(310 / 25.4 * 200)));
  const auto bad = run("board --board charuco:7x5:0.04:0.05 --out " + (d / "x.svg").string());
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.out.find("smaller than the square"), std::string::npos) << bad.out;
  EXPECT_FALSE(fs::exists(d / "x.svg"));
}

TEST(CalibCli, BoardViewsWriteImagesAndTruth) {
  const fs::path& d = views_dir();
  std::ifstream in(d / "truth.json");
  const auto truth = nlohmann::json::parse(in);
  ASSERT_EQ(truth["views"].size(), 14u);
  EXPECT_EQ(truth["board"], kBoard);
  for (const auto& v : truth["views"]) {
    EXPECT_TRUE(fs::exists(d / v["image"].get<std::string>()));
    EXPECT_GE(v["corners"].size(), 12u);
  }
  const auto m = ips::CameraModel::load(d / "true_intrinsics.yaml");
  const auto orig = ips::CameraModel::load(std::string(IPS_CONFIG_DIR) + "/scenes/lenses/pinhole_wide.yaml");
  EXPECT_EQ(m.K(), orig.K());
  EXPECT_EQ(m.D(), orig.D());
}

TEST(CalibCli, CalibrateOfflineWritesLoadableIntrinsicsReportAndJson) {
  const fs::path& views = views_dir();
  const fs::path d = temp_dir("offline");
  const auto r = run("calibrate --images " + views.string() + " --board " + kBoard + " --model pinhole --out " +
                         (d / "intr.yaml").string() + " --report " + (d / "report.png").string() + " --json",
                     false);
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_LE(j["rms_px"].get<double>(), 0.3);
  EXPECT_EQ(j["images"].get<int>(), 14);
  EXPECT_GT(j["coverage"].get<double>(), 0.3);
  EXPECT_GT(j["max_field_deg"].get<double>(), 40.0);
  const auto model = ips::CameraModel::load(d / "intr.yaml");
  EXPECT_EQ(model.kind(), ips::CameraModel::Kind::kPinhole);
  EXPECT_NEAR(model.K()(0, 0), 620.0, 3.0);
  std::ifstream in(d / "intr.yaml");
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  for (const char* key : {"board: \"charuco:7x5:0.04:0.03:DICT_5X5_100\"", "images: 14", "rms_px:", "date: 20"})
    EXPECT_NE(text.find(key), std::string::npos) << key;
  const cv::Mat report = cv::imread((d / "report.png").string());
  EXPECT_EQ(report.cols, 1280);
}

TEST(CalibCli, BadInputExitsTwoAndWritesNothing) {
  const fs::path& views = views_dir();
  const fs::path d = temp_dir("bad");
  const std::string out = (d / "intr.yaml").string();
  auto expect_error = [&](const std::string& args, const std::string& what) {
    const auto r = run("calibrate " + args + " --out " + out);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << args << "\n" << r.out;
    EXPECT_FALSE(fs::exists(out)) << args;
  };
  // No board in any image.
  fs::create_directories(d / "blank");
  for (int i = 0; i < 3; ++i)
    cv::imwrite((d / "blank" / numbered("b%d.png", i)).string(), cv::Mat(480, 640, CV_8U, cv::Scalar(128)));
  expect_error("--images " + (d / "blank").string() + " --board " + kBoard, "no board");
  // Too few views.
  fs::create_directories(d / "few");
  for (int i = 0; i < 3; ++i) fs::copy_file(views / numbered("view_%03d.jpg", i), d / "few" / numbered("v%d.jpg", i));
  expect_error("--images " + (d / "few").string() + " --board " + kBoard, "too few views");
  // Images of different sizes.
  fs::create_directories(d / "mixed");
  for (int i = 0; i < 8; ++i) fs::copy_file(views / numbered("view_%03d.jpg", i), d / "mixed" / numbered("v%d.jpg", i));
  cv::imwrite((d / "mixed" / "z.png").string(), cv::Mat(480, 640, CV_8U, cv::Scalar(128)));
  expect_error("--images " + (d / "mixed").string() + " --board " + kBoard, "different sizes");
  // An unreadable image.
  fs::create_directories(d / "broken");
  for (int i = 0; i < 8; ++i)
    fs::copy_file(views / numbered("view_%03d.jpg", i), d / "broken" / numbered("v%d.jpg", i));
  std::ofstream(d / "broken" / "v9.jpg") << "not a jpeg";
  expect_error("--images " + (d / "broken").string() + " --board " + kBoard, "v9.jpg");
  // A bad board spec, a bad model.
  expect_error("--images " + views.string() + " --board charuco:7x5:0.04", "board spec");
  expect_error("--images " + views.string() + " --model fish", "--model must be");
  // Live from a device that is not there.
  expect_error("--device /dev/v4l/by-id/no-such-camera", "cannot open");
  EXPECT_FALSE(fs::exists(d / "intr_views"));
}

TEST(CalibCli, LiveModeOnAFileSourceKeepsStillViews) {
  // A person holding the board still for a moment at each pose: every view twice in a row,
  // played by the daemon's file source from a config, as a camera would deliver them.
  const fs::path& views = views_dir();
  const fs::path d = temp_dir("live");
  fs::create_directories(d / "frames");
  int k = 0;
  for (int i = 0; i < 14; ++i) {
    char src[32];
    std::snprintf(src, sizeof src, "view_%03d.jpg", i);
    for (int rep = 0; rep < 2; ++rep) {
      char dst[32];
      std::snprintf(dst, sizeof dst, "f%04d.jpg", k++);
      fs::copy_file(views / src, d / "frames" / dst);
    }
  }
  std::ofstream(d / "ipsd.yaml") << "cameras:\n  - {name: cam0, source: file, path: frames, fps: 200, "
                                    "loop: false, intrinsics: cam0.yaml}\n"
                                    "markers: {dictionary: DICT_4X4_100, edge_length: 0.2}\n"
                                    "model_file: model.json\n";
  const auto r = run("calibrate --config " + (d / "ipsd.yaml").string() + " --camera cam0 --board " + kBoard +
                     " --model pinhole --views 12 --out " + (d / "cam0.yaml").string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("views kept"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("missing:"), std::string::npos) << r.out;
  int saved = 0;
  for (const auto& e : fs::directory_iterator(d / "cam0_views")) saved += e.path().extension() == ".png";
  EXPECT_GE(saved, 8);
  EXPECT_LE(saved, 12);
  const auto model = ips::CameraModel::load(d / "cam0.yaml");
  EXPECT_NEAR(model.K()(0, 0), 620.0, 5.0);
  // The saved views calibrate offline to the same result.
  const auto again = run("calibrate --images " + (d / "cam0_views").string() + " --board " + kBoard +
                         " --model pinhole --out " + (d / "again.yaml").string());
  ASSERT_EQ(again.status, 0) << again.out;
  EXPECT_NEAR(ips::CameraModel::load(d / "again.yaml").K()(0, 0), model.K()(0, 0), 1e-6);
}
