// The real ipsd with the mavlink and subscriptions outputs next to a plain unicast one, on
// three synthetic cameras with one moving robot: the MAVLink frames decoded by node-mavlink
// must carry exactly the unicast stream's positions in the autopilot's frame (and the
// simulator's truth); `ips listen --subscribe` and tools/ipsd_client.py --subscribe get a
// stream, a client from a disallowed subnet does not; bad output configs exit 2 naming the key.
#include <poll.h>

#include <cmath>
#include <map>
#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/clock.h"
#include "ips/output/mavlink_frame.h"
#include "ips/output/mavlink_pose.h"
#include "ips/output/packet_codec.h"
#include "ips/sim/scene.h"
#include "mavlink_decoder.h"
#include "plane_model.h"
#include "process_util.h"
#include "published_scene.h"

namespace ips {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;

class OutputsIpsdTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("outputs_ipsd_test_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    std::ofstream(*dir_ / "scene.yaml") << test::published_scene_with(R"(markers:
  - id: 1
    length: 0.20
    height: 0.15
    trajectory: {type: circle, center: [2.4, 2.4], radius: 1.0, speed: 0.3}
)");
    test::write_plane_model(*dir_ / "scene.yaml", *dir_ / "model.json");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string config(const std::string& outputs) {
    std::string c = "cameras:\n";
    for (const char* name : {"red", "white", "black"})
      c += std::string("  - {name: ") + name + ", source: synthetic, scene: scene.yaml, fps: 4}\n";
    c += "markers:\n  ids:\n    1: {height: 0.15}\n";
    c += "model_file: model.json\n";
    c += "fusion: {method: mean, window: 0.02, max_wait: 0.5, kalman: {enabled: true}}\n";
    c += "status: {interval: 2, socket: " + (*dir_ / "status.sock").string() + "}\n";
    return c + "outputs:\n" + outputs;
  }
  static fs::path* dir_;
};
fs::path* OutputsIpsdTest::dir_ = nullptr;

int json_lines(const std::string& text) {
  int n = 0;
  for (std::size_t at = text.find("{\"type\":\"ips.positions\""); at != std::string::npos;
       at = text.find("{\"type\":\"ips.positions\"", at + 1))
    ++n;
  return n;
}

TEST_F(OutputsIpsdTest, MavlinkMatchesTheStreamAndSubscribersGetTheirOwn) {
  const std::string node_missing = test::node_missing_reason();
  if (node_missing.empty()) {
    ASSERT_TRUE(test::decoder_installed()) << "node-mavlink is not installed: run tools/setup.sh";
  }
  test::UdpReceiver plain, mav;
  const std::uint16_t sub_port = test::free_udp_port();
  const fs::path cfg = *dir_ / "ipsd.yaml";
  std::ofstream(cfg) << config("  - {type: unicast, address: 127.0.0.1, port: " + std::to_string(plain.port) + "}\n" +
                               "  - {type: mavlink, address: 127.0.0.1, port: " + std::to_string(mav.port) +
                               ", messages: [vision_position_estimate, odometry], yaw_offset_deg: 30, vehicles: "
                               "[{marker: 1, system_id: 42}]}\n" +
                               "  - {type: subscriptions, address: 127.0.0.1, port: " + std::to_string(sub_port) +
                               ", allow: [127.0.0.1/32]}\n");
  const fs::path log = *dir_ / "ipsd.log";
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", cfg.string()}, log);
  const test::ChildGuard guard(pid);

  // Both streams until 10 pose frames came (4 fps: ~3 s after the first).
  // Unicast records of marker 1 by capture time, us (several updates may share a frame instant).
  std::multimap<std::int64_t, MarkerRecord> by_capture_us;
  auto keep = [&](const std::vector<std::uint8_t>& bytes) {
    const Datagram g = decode_datagram(bytes);
    for (const MarkerRecord& m : g.markers) by_capture_us.emplace(g.capture_realtime_ns / 1000, m);
  };
  std::vector<std::vector<std::uint8_t>> frames;
  int poses = 0;
  const std::int64_t end = monotonic_ns() + static_cast<std::int64_t>(40e9 * test::kTimeScale);
  while (poses < 10 && monotonic_ns() < end) {
    if (auto d = plain.receive(20)) keep(*d);
    if (auto f = mav.receive(20)) {
      poses += f->size() > 9 && (*f)[7] == mavlink::kMsgVisionPositionEstimate;
      frames.push_back(std::move(*f));
    }
  }
  for (int i = 0; i < 20; ++i)  // the unicast datagrams of the last frames
    if (auto d = plain.receive(50)) keep(*d);
  ASSERT_GE(poses, 10) << test::read_file(log);

  // Subscribers, while the daemon runs: the C++ and the Python client, then a disallowed one.
  const fs::path listen_log = *dir_ / "listen.log";
  EXPECT_EQ(test::run({test::bin("ips"), "listen", "--subscribe", "127.0.0.1:" + std::to_string(sub_port), "--json",
                       "--count", "3", "--lease", "10", "--duration", std::to_string(30 * test::kTimeScale)},
                      listen_log, std::chrono::seconds(60)),
            0);
  const std::string listened = test::read_file(listen_log);
  EXPECT_NE(listened.find("subscribed at 127.0.0.1:" + std::to_string(sub_port)), std::string::npos) << listened;
  EXPECT_EQ(json_lines(listened), 3) << listened;
  if (fs::exists("/usr/bin/python3")) {
    const fs::path py_log = *dir_ / "python.log";
    EXPECT_EQ(test::run({"/usr/bin/python3", std::string(IPS_SOURCE_DIR) + "/tools/ipsd_client.py", "--subscribe",
                         "127.0.0.1:" + std::to_string(sub_port), "--count", "3"},
                        py_log, std::chrono::seconds(60)),
              0);
    const std::string py = test::read_file(py_log);
    EXPECT_NE(py.find("subscribed (lease 30 s)"), std::string::npos) << py;
    EXPECT_NE(py.find("3 datagrams, 0 malformed"), std::string::npos) << py;
  }
  const fs::path outsider_log = *dir_ / "outsider.log";
  EXPECT_EQ(test::run({test::bin("ips"), "listen", "--subscribe", "127.0.0.1:" + std::to_string(sub_port), "--bind",
                       "127.0.0.2:0", "--json", "--duration", "2"},
                      outsider_log, std::chrono::seconds(30)),
            0);
  const std::string outsider = test::read_file(outsider_log);
  EXPECT_EQ(json_lines(outsider), 0) << outsider;
  EXPECT_EQ(outsider.find("subscribed at"), std::string::npos) << outsider;

  const auto status = nlohmann::json::parse(test::read_unix_socket((*dir_ / "status.sock").string()));
  ASSERT_EQ(status["outputs"].size(), 3u) << status.dump();
  const auto& subs = status["outputs"][2];
  EXPECT_GE(subs.value("accepted", 0), 2) << subs.dump();
  EXPECT_GE(subs.value("refused_subnet", 0), 1) << subs.dump();
  EXPECT_EQ(subs.value("unverified_bytes_out", 1), subs.value("challenges", 0) * 28) << subs.dump();
  const auto& mav_status = status["outputs"][1];
  EXPECT_EQ(mav_status["output"], "mavlink 127.0.0.1:" + std::to_string(mav.port) + " (1 vehicle(s))");
  EXPECT_GE(mav_status.value("datagrams", 0), 2 * poses);
  // `ips status` prints the type-specific counters after the common ones.
  const fs::path status_log = *dir_ / "status.log";
  EXPECT_EQ(test::run({test::bin("ips"), "status", "--socket", (*dir_ / "status.sock").string()}, status_log), 0);
  const std::string printed = test::read_file(status_log);
  EXPECT_NE(printed.find("output subscriptions on 127.0.0.1:" + std::to_string(sub_port)), std::string::npos)
      << printed;
  EXPECT_NE(printed.find("refused_subnet "), std::string::npos) << printed;
  EXPECT_EQ(printed.find("refused_subnet 0"), std::string::npos) << printed;  // the outsider resends each second
  // `ipsd --check` on the running daemon's config (systemd's ExecCondition, an admin's check)
  // neither fails on the subscriptions port the daemon holds nor takes its status socket.
  const fs::path check_log = *dir_ / "check.log";
  EXPECT_EQ(test::run({test::bin("ipsd"), "--config", cfg.string(), "--check"}, check_log), 0)
      << test::read_file(check_log);
  EXPECT_EQ(test::run({test::bin("ips"), "status", "--socket", (*dir_ / "status.sock").string()}, status_log), 0)
      << "ipsd --check took the running daemon's status socket";
  const std::int64_t epoch = status["synthetic_epoch_mono_ns"];
  ::kill(pid, SIGTERM);
  EXPECT_EQ(test::wait_exit(pid, std::chrono::seconds(10)), 0);

  if (!node_missing.empty()) GTEST_SKIP() << node_missing << " (the MAVLink frames were received but not decoded)";
  std::string error;
  const auto doc = test::decode_mavlink(frames, *dir_ / "frames.bin", error);
  ASSERT_TRUE(doc) << error;
  EXPECT_EQ((*doc)["crc_errors"], 0);
  EXPECT_EQ((*doc)["invalid"], 0);
  ASSERT_EQ((*doc)["packets"].size(), frames.size());
  const auto scene = sim::Scene::load(*dir_ / "scene.yaml");
  const std::int64_t real_minus_mono = realtime_minus_monotonic_ns();
  int matched = 0, heartbeats = 0;
  double worst = 0;
  // A gap longer than track_gap (fusion.kalman.reset_after, 0.5 s) between poses starts a new
  // track, counted by reset_counter: none on a quiet machine; a busy one can starve all three
  // cameras that long (seen beside other work), and then the counter must say so.
  std::int64_t last_pose_usec = -1;
  int gaps = 0;
  for (const auto& p : (*doc)["packets"]) {
    SCOPED_TRACE(p.dump());
    EXPECT_EQ(p["sysid"], 42);
    EXPECT_EQ(p["compid"], 197);
    const int msgid = p["msgid"];
    const auto& f = p["fields"];
    if (msgid == 0) {
      ++heartbeats;
      continue;
    }
    ASSERT_TRUE(msgid == 102 || msgid == 331);
    const std::int64_t usec = std::stoll(f[msgid == 102 ? "usec" : "time_usec"].get<std::string>());
    if (msgid == 102) {
      if (last_pose_usec >= 0 && usec - last_pose_usec > 500'000) ++gaps;
      last_pose_usec = usec;
    }
    // The unicast record of the same instant that this frame carries (the closest one).
    const auto [first, last] = by_capture_us.equal_range(usec);
    if (first == last) continue;  // its unicast datagram was not received (end of the run)
    MavlinkPose want;
    double best = 1e9;
    for (auto it = first; it != last; ++it) {
      const MavlinkPose candidate = lab_to_ned(it->second, 30 * kDeg, 0.0);
      const double d = std::hypot(candidate.n - test::json_float(f["x"]), candidate.e - test::json_float(f["y"]));
      if (d < best) best = d, want = candidate;
    }
    // The unicast stream carries float32 positions: the same values to float precision.
    EXPECT_NEAR(test::json_float(f["x"]), want.n, 1e-5);
    EXPECT_NEAR(test::json_float(f["y"]), want.e, 1e-5);
    EXPECT_NEAR(test::json_float(f["z"]), want.d, 1e-5);
    const auto& cov = f[msgid == 102 ? "covariance" : "pose_covariance"];
    for (int k : {0, 6, 11}) {
      EXPECT_GT(test::json_float(cov[k]), 0.0) << "variance " << k;
      EXPECT_LT(test::json_float(cov[k]), 1e-2) << "variance " << k;
    }
    if (msgid == 102) {
      EXPECT_NEAR(test::json_float(f["yaw"]), want.heading, 1e-5);
      EXPECT_EQ(f["reset_counter"], gaps);
      // And the simulator's truth, converted by hand: north/east of lab (x, y) at 30 degrees.
      const double t = 1e-9 * static_cast<double>(usec * 1000 - real_minus_mono - epoch);
      const sim::MarkerPose truth = scene.marker_pose(1, t);
      const double n = truth.x * std::cos(30 * kDeg) + truth.y * std::sin(30 * kDeg);
      const double e = truth.x * std::sin(30 * kDeg) - truth.y * std::cos(30 * kDeg);
      const double err = std::hypot(test::json_float(f["x"]) - n, test::json_float(f["y"]) - e);
      worst = std::max(worst, err);
      EXPECT_LT(err, 0.05);
      EXPECT_NEAR(test::json_float(f["z"]), -0.15, 1e-4);
      ++matched;
    } else {
      const double h = want.heading;
      EXPECT_NEAR(test::json_float(f["q"][0]), std::cos(h / 2), 1e-5);
      EXPECT_NEAR(test::json_float(f["q"][3]), std::sin(h / 2), 1e-5);
      EXPECT_NEAR(test::json_float(f["vx"]), std::cos(h) * want.vn + std::sin(h) * want.ve, 1e-4);
      EXPECT_NEAR(test::json_float(f["vy"]), -std::sin(h) * want.vn + std::cos(h) * want.ve, 1e-4);
      EXPECT_EQ(f["frame_id"], 20);
      EXPECT_EQ(f["child_frame_id"], 12);
    }
  }
  EXPECT_GE(heartbeats, 1);
  EXPECT_GE(matched, 5) << "too few MAVLink poses matched a unicast datagram";
  std::printf(
      "[ mavlink ] %zu frames, %d poses matched to the unicast stream, worst error vs truth %.2f cm, %d gaps "
      "(track restarts)\n",
      frames.size(), matched, worst * 100, gaps);
}

TEST_F(OutputsIpsdTest, BadOutputConfigurationsExitWith2NamingTheKey) {
  struct Case {
    std::string outputs, message;
  };
  const std::vector<Case> cases = {
      {"  - {type: mavlnk, address: 127.0.0.1, port: 14550}\n", "outputs[0].type: unknown value 'mavlnk'"},
      {"  - {type: mavlink, address: 127.0.0.1, port: 14550, vehicles: [{marker: 1, system_id: 300}]}\n",
       "outputs[0].vehicles[0].system_id: must be 1..255"},
      {"  - {type: subscriptions, port: 5010, allow: [192.168.1.0/33]}\n",
       "outputs[0].allow[0]: '192.168.1.0/33' is not an IPv4 subnet"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.message);
    const fs::path cfg = *dir_ / "bad.yaml";
    std::ofstream(cfg) << config(c.outputs);
    const fs::path log = *dir_ / "bad.log";
    fs::remove(log);
    EXPECT_EQ(test::run({test::bin("ipsd"), "--config", cfg.string()}, log, std::chrono::seconds(60)), 2);
    const std::string out = test::read_file(log);
    EXPECT_NE(out.find(c.message), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace ips
