// `ips cameras` against emulated devices in a scratch /dev (tests/capture/v4l2_emulator.cpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "emu_control.h"
#include "emu_harness.h"

namespace {

namespace fs = std::filesystem;

TEST(IpsCameras, ListsDevicesFormatsSizesRatesAndByIdLinks) {
  ips::test::TempDir dir;
  fs::create_directories(dir / "dev/v4l/by-id");
  for (const char* node : {"video0", "video1", "video10"}) std::ofstream(dir / ("dev/" + std::string(node)));
  fs::create_symlink("../../video0", dir / "dev/v4l/by-id/usb-Emu_Ceiling_Cam_SN1-video-index0");
  ips::test::write_emu_control(dir / "a.conf", {{"formats", "MJPG,YUYV"},
                                                {"sizes", "1920x1080,1280x720"},
                                                {"fps", "30"},
                                                {"card", "Ceiling Cam A"},
                                                {"bus", "usb-0000:00:14.0-2"}});
  ips::test::write_emu_control(dir / "b.conf", {{"formats", "YUYV"},
                                                {"sizes", "640x480"},
                                                {"fps", "15"},
                                                {"card", "Ceiling Cam B"},
                                                {"unsupported_controls",
                                                 "gain,focus_auto,exposure_auto,"
                                                 "exposure_absolute"}});
  const auto r =
      ips::test::run_emulated({IPS_TOOL, "cameras", "--dev-dir", dir / "dev"},
                              {{dir / "dev/video0", dir / "a.conf"}, {dir / "dev/video1", dir / "b.conf"}}, dir.str());
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::string& out = r.out;
  const std::string expected_a = dir / "dev/video0" +
                                 ": Ceiling Cam A (driver ips-v4l2-emu, bus usb-0000:00:14.0-2)\n"
                                 "  link: " +
                                 dir / "dev/v4l/by-id/usb-Emu_Ceiling_Cam_SN1-video-index0" +
                                 "\n"
                                 "  MJPG (Motion-JPEG)\n"
                                 "    1920x1080 @ 30 fps\n"
                                 "    1280x720 @ 30 fps\n"
                                 "  YUYV (YUYV 4:2:2)\n"
                                 "    1920x1080 @ 30 fps\n"
                                 "    1280x720 @ 30 fps\n"
                                 "  controls:\n"
                                 "    auto_exposure: now true\n"
                                 "    exposure: 0.0003..0.2047 s, now 0.0156 s\n"
                                 "    gain: 0..255, now 0\n"
                                 "    autofocus: now true\n"
                                 "    power_line_hz: now 50\n";
  EXPECT_NE(out.find(expected_a), std::string::npos) << out;
  const std::string expected_b = dir / "dev/video1" +
                                 ": Ceiling Cam B (driver ips-v4l2-emu, bus emu)\n"
                                 "  YUYV (YUYV 4:2:2)\n"
                                 "    640x480 @ 15 fps\n"
                                 "  controls:\n"
                                 "    power_line_hz: now 50\n";
  EXPECT_NE(out.find(expected_b), std::string::npos) << out;
  // video10 is listed after video1 (numeric order) and is not a V4L2 device.
  EXPECT_GT(out.find(dir / "dev/video10: cannot query: not a V4L2 device"), out.find(expected_b)) << out;
  EXPECT_NE(out.find("2 capture device(s)"), std::string::npos) << out;
}

// --probe reads one MJPEG frame from each camera: with a restart marker every MCU row (40
// MCUs of 16 x 16 px in a 640-px 4:2:0 row), without, and a camera with no MJPEG at all.
TEST(IpsCameras, ProbeSaysWhetherFramesCarryRestartMarkers) {
  ips::test::TempDir dir;
  fs::create_directories(dir / "dev");
  for (const char* node : {"video0", "video1", "video2"}) std::ofstream(dir / ("dev/" + std::string(node)));
  cv::Mat card(480, 640, CV_8UC3);
  cv::randu(card, 0, 255);
  for (const auto& [name, interval] : {std::pair{"rst", 40}, std::pair{"plain", 0}}) {
    fs::create_directories(dir / name);
    std::vector<std::uint8_t> jpeg;
    cv::imencode(".jpg", card, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80, cv::IMWRITE_JPEG_RST_INTERVAL, interval});
    std::ofstream(dir / name + "/0.jpg", std::ios::binary)
        .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
  }
  ips::test::write_emu_control(dir / "a.conf",
                               {{"formats", "MJPG"}, {"sizes", "640x480"}, {"fps", "30"}, {"frames", dir / "rst"}});
  ips::test::write_emu_control(dir / "b.conf",
                               {{"formats", "MJPG"}, {"sizes", "640x480"}, {"fps", "30"}, {"frames", dir / "plain"}});
  ips::test::write_emu_control(dir / "c.conf", {{"formats", "YUYV"}, {"sizes", "640x480"}, {"fps", "30"}});
  const auto r = ips::test::run_emulated({IPS_TOOL, "cameras", "--dev-dir", dir / "dev", "--probe"},
                                         {{dir / "dev/video0", dir / "a.conf"},
                                          {dir / "dev/video1", dir / "b.conf"},
                                          {dir / "dev/video2", dir / "c.conf"}},
                                         dir.str());
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto a = r.out.find(dir / "dev/video0:"), b = r.out.find(dir / "dev/video1:"),
             c = r.out.find(dir / "dev/video2:");
  ASSERT_TRUE(a != std::string::npos && b != std::string::npos && c != std::string::npos) << r.out;
  const auto rst = r.out.find(
      "  restart markers: every 40 MCUs in a 640x480 frame (a region decode can start every 1 MCU row(s), 16 px)");
  const auto none = r.out.find("  restart markers: none in a 640x480 frame");
  const auto na = r.out.find("  restart markers: no MJPEG format: not applicable");
  EXPECT_TRUE(rst > a && rst < b) << r.out;
  EXPECT_TRUE(none > b && none < c) << r.out;
  EXPECT_TRUE(na > c && na != std::string::npos) << r.out;
}

TEST(IpsCameras, SaysSoWhenThereIsNoCamera) {
  ips::test::TempDir dir;
  fs::create_directories(dir / "dev");
  const auto r = ips::test::run_emulated({IPS_TOOL, "cameras", "--dev-dir", dir / "dev"}, {}, dir.str());
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("No V4L2 video devices in " + dir / "dev"), std::string::npos) << r.out;
}

}  // namespace
