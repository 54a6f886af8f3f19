// ipsd end to end on two emulated V4L2 cameras (tests/capture/v4l2_emulator.cpp): the real
// daemon, the real V4L2 capture path, frames rendered by the simulator from the published
// layout, positions received over UDP and compared with the scene's truth. Then one camera
// is unplugged (the other keeps publishing) and replugged (it comes back within the back-off).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <thread>

#include "child_process.h"
#include "emu_control.h"
#include "emu_harness.h"
#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"
#include "loopback_udp.h"
#include "published_scene.h"

namespace {

namespace fs = std::filesystem;
using ips::test::read_text;

// Frame rate of the emulated cameras: low, so that a loaded 2-core CI machine (ASan) keeps
// up with detection on two 1080p streams.
constexpr int kFps = 5;
// The supervisor's back-off: first retry after 0.5 s, doubling up to 10 s (daemon section).
constexpr double kMaxBackoffBeforeReplugS = 4.0;

using ips::support::UdpReceiver;

class IpsdOnEmulatedCameras : public ::testing::Test {
 protected:
  void SetUp() override {
    // The published layout with two robots standing still, both seen by red and white.
    const std::string scene = ips::test::published_scene_with(R"(markers:
  - id: 1
    length: 0.20
    x: 2.2
    y: 1.55
    height: 0.15
  - id: 2
    length: 0.20
    x: 2.8
    y: 1.7
    height: 0.10
)");
    std::ofstream(dir_ / "scene.yaml") << scene;
    // The camera->world model: simulated calibration pairs, plane mapper (as tools/demo.sh).
    const std::string ips = IPS_TOOL;
    for (const auto& argv : std::vector<std::vector<std::string>>{
             {ips, "sim", "collect", "--scene", dir_ / "scene.yaml", "--camera", "red", "--camera", "white", "--points",
              "25", "--out", dir_ / "pairs.csv"},
             {ips, "fit", "--data", dir_ / "pairs.csv", "--method", "plane", "--out", dir_ / "model.json"}}) {
      const auto r = ips::test::run_emulated(argv, {}, dir_.str());
      ASSERT_EQ(r.status, 0) << r.out << r.err;
    }
    // Each camera's frames, as its MJPEG stream would carry them (colour JPEG, grey chroma).
    scene_ = ips::sim::Scene::load(dir_ / "scene.yaml");
    for (const char* name : {"red", "white"}) {
      const ips::sim::CameraRenderer renderer(scene_, scene_.camera_index(name));
      fs::create_directories(dir_ / (std::string("frames_") + name));
      cv::Mat gray;
      for (int k = 0; k < 3; ++k) {
        renderer.render(0.0, gray, static_cast<std::uint64_t>(k));
        const auto jpeg = ips::sim::encode_jpeg(gray, 90, true);
        std::ofstream(dir_ / ("frames_" + std::string(name) + "/f" + std::to_string(k) + ".jpg"), std::ios::binary)
            .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
      }
      for (const auto& t : renderer.truth(0.0)) ASSERT_TRUE(t.visible) << name << " does not see marker " << t.id;
      ips::test::write_emu_control(dir_ / (std::string(name) + ".conf"),
                                   {{"formats", "MJPG"},
                                    {"sizes", "1920x1080"},
                                    {"fps", std::to_string(kFps)},
                                    {"frames", dir_ / ("frames_" + std::string(name))},
                                    {"card", std::string("Emulated ") + name}});
    }
  }

  std::string config(std::uint16_t port) const {
    std::string c = "cameras:\n";
    int i = 0;
    for (const char* name : {"red", "white"})
      c += std::string("  - {name: ") + name + ", source: v4l2, device: /dev/video-emu" + std::to_string(i++) +
           ", fps: " + std::to_string(kFps) + ", intrinsics: " + IPS_TEST_DATA_DIR + "/ou2023/intrinsics_" + name +
           ".yaml, controls: {exposure: 0.004, power_line_hz: 50, autofocus: false}}\n";
    c += "markers:\n  ids:\n    1: {height: 0.15}\n    2: {height: 0.10}\n";
    c += "model_file: model.json\n";
    c += "fusion: {method: mean, window: 0.02, max_wait: 0.3}\n";
    c += "outputs:\n  - {type: unicast, address: 127.0.0.1, port: " + std::to_string(port) + ", format: binary}\n";
    return c;
  }

  ips::test::TempDir dir_;
  ips::sim::Scene scene_;
};

// Capture time (CLOCK_MONOTONIC ns) of one marker of a datagram.
std::int64_t capture_ns(const ips::Datagram& d, const ips::MarkerRecord& m) {
  return d.capture_monotonic_ns + 1000LL * m.dt_us;
}

// Receives until `done(datagram)` returns true or `seconds` pass (the deadline is only
// reached when something is wrong). Returns whether `done` was satisfied.
bool receive_until(UdpReceiver& rx, double seconds, const std::function<bool(const ips::Datagram&)>& done) {
  const std::int64_t end = ips::monotonic_ns() + static_cast<std::int64_t>(seconds * 1e9);
  while (ips::monotonic_ns() < end)
    if (auto bytes = rx.receive(50); bytes && done(ips::decode_datagram(*bytes))) return true;
  return false;
}

TEST_F(IpsdOnEmulatedCameras, StreamsBothCamerasSurvivesUnplugAndResumesAfterReplug) {
  UdpReceiver rx;
  ASSERT_NE(rx.port, 0);
  std::ofstream(dir_ / "ipsd.yaml") << config(rx.port);
  const std::string log = dir_ / "ipsd.log";
  const std::map<std::string, std::string> devices{{"/dev/video-emu0", dir_ / "red.conf"},
                                                   {"/dev/video-emu1", dir_ / "white.conf"}};
  const pid_t pid = ips::test::spawn_emulated({std::string(IPS_BINARY_DIR) + "/ipsd", "--config", dir_ / "ipsd.yaml"},
                                              devices, log, log);
  ASSERT_GT(pid, 0);
  const ips::support::ChildGuard stopper(pid);  // never leave the daemon running, whatever fails

  // 1. Both cameras stream, and every position matches the truth.
  int seen_by[2] = {0, 0};
  const bool both = receive_until(rx, 60.0, [&](const ips::Datagram& d) {
    for (const auto& m : d.markers) {
      EXPECT_TRUE(m.id == 1 || m.id == 2) << m.id;
      const auto truth = scene_.marker_pose(static_cast<int>(m.id), 0.0);
      EXPECT_LT(std::hypot(m.x - truth.x, m.y - truth.y), 0.03)
          << "marker " << m.id << " (" << m.x << ", " << m.y << ") cameras 0x" << std::hex << m.camera_mask;
      EXPECT_NEAR(m.z, m.id == 1 ? 0.15 : 0.10, 1e-6);
      for (int bit : {0, 1}) seen_by[bit] += (m.camera_mask >> bit) & 1;
    }
    return seen_by[0] >= 4 && seen_by[1] >= 4;
  });
  ASSERT_TRUE(both) << "positions from red: " << seen_by[0] << ", white: " << seen_by[1] << "\n" << read_text(log);

  // 2. Unplug red (camera 0): white keeps publishing; nothing red captured after the unplug.
  const std::int64_t unplugged = ips::monotonic_ns();
  ips::test::set_emu_control(dir_ / "red.conf", "present", "0");
  int from_white = 0, late_red = 0;
  // No stall: fusion never waits for the unplugged camera, so white's records keep their own
  // rate; the largest gap between them (by arrival) is measured from the first one after the unplug.
  std::int64_t last_white = 0, widest_gap = 0;
  const bool white_goes_on = receive_until(rx, 30.0, [&](const ips::Datagram& d) {
    for (const auto& m : d.markers) {
      late_red += (m.camera_mask & 1) && capture_ns(d, m) > unplugged;
      from_white += (m.camera_mask >> 1) & 1;
      if ((m.camera_mask >> 1) & 1) {
        const std::int64_t now = ips::monotonic_ns();
        if (last_white != 0) widest_gap = std::max(widest_gap, now - last_white);
        last_white = now;
      }
    }
    // Unplugged for 2 s at least: reopen attempts at +0.5 s and +1.5 s fail (the second quietly).
    return from_white >= 6 && ips::monotonic_ns() - unplugged > 2'000'000'000;
  });
  EXPECT_TRUE(white_goes_on) << "white stopped publishing when red was unplugged\n" << read_text(log);
  EXPECT_EQ(late_red, 0) << read_text(log);
  std::printf("[ ipsd    ] red unplugged: white's widest gap %.0f ms (frame period %d ms)\n",
              1e-6 * static_cast<double>(widest_gap), 1000 / kFps);
  // 3 frame periods: one frame may be skipped by white's own reader, plus scheduling slack.
  EXPECT_LT(widest_gap, 3 * 1'000'000'000LL / kFps) << read_text(log);

  // 3. Replug: red comes back within the back-off in force (at most 4 s by now), plus the
  // time to open, capture and process a frame.
  const std::int64_t replugged = ips::monotonic_ns();
  ips::test::set_emu_control(dir_ / "red.conf", "present", "1");
  std::int64_t back = 0;
  const bool red_back = receive_until(rx, 30.0, [&](const ips::Datagram& d) {
    for (const auto& m : d.markers)
      if ((m.camera_mask & 1) && capture_ns(d, m) > replugged) back = ips::monotonic_ns();
    return back != 0;
  });
  ASSERT_TRUE(red_back) << "red did not come back\n" << read_text(log);
  const double resumed_after_s = static_cast<double>(back - replugged) * 1e-9;
  EXPECT_LT(resumed_after_s, kMaxBackoffBeforeReplugS + 3.0) << read_text(log);
  std::printf("[ ipsd    ] red unplugged for %.2f s, resumed %.2f s after replug\n",
              static_cast<double>(replugged - unplugged) * 1e-9, resumed_after_s);

  // Logged once per change of state, not per attempt: the streaming error, then the first
  // failed reopen (the later ones fail the same way and stay quiet).
  const std::string text = read_text(log);
  std::istringstream lines(text);
  int warnings = 0, attempts_logged = 0;
  for (std::string line; std::getline(lines, line);) {
    warnings += line.find("red: ") != std::string::npos && line.find("retrying") != std::string::npos;
    attempts_logged += line.find("red: ") != std::string::npos && line.find("is back") != std::string::npos;
  }
  EXPECT_EQ(warnings, 2) << text;
  EXPECT_EQ(attempts_logged, 1) << text;

  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  EXPECT_EQ(ips::support::wait_exit(pid, std::chrono::seconds(30)), std::optional<int>(0)) << read_text(log);
}

}  // namespace
