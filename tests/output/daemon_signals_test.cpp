// The real ipsd with every output type, the web view and the range input on: `systemctl reload` (SIGHUP) reloads
// and keeps the stream and its subscribers, SIGTERM stops it with exit 0, and no thread of the
// process — ours, Cyclone DDS's, CivetWeb's — has the stop/reload signals unblocked (a thread
// that had them would take SIGHUP itself and die of it: the ROS 2 writer once did).
#include <signal.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/clock.h"
#include "plane_model.h"
#include "process_util.h"
#include "published_scene.h"
#include "ros2_test_util.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

constexpr int kDomain = 66;  // apart from the other ROS 2 tests' domains

/// How often `needle` occurs in `text`.
int count(const std::string& text, const std::string& needle) {
  int n = 0;
  for (auto at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

/// The blocked-signal mask of every thread of `pid` (its SigBlk line in /proc), by thread id.
std::map<std::string, std::uint64_t> blocked_masks(pid_t pid) {
  std::map<std::string, std::uint64_t> masks;
  for (const auto& task : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
    std::ifstream status(task.path() / "status");
    std::string line;
    while (std::getline(status, line))
      if (line.rfind("SigBlk:", 0) == 0) masks[task.path().filename()] = std::stoull(line.substr(7), nullptr, 16);
  }
  return masks;
}

/// The thread's name (/proc/<pid>/task/<tid>/comm), for failure messages.
std::string thread_name(pid_t pid, const std::string& tid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/task/" + tid + "/comm");
  std::string name;
  std::getline(in, name);
  return name;
}

class DaemonSignalsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    test::use_loopback_dds();
    dir_ = new fs::path(fs::temp_directory_path() / ("daemon_signals_test_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    std::ofstream(*dir_ / "scene.yaml") << test::published_scene_with(test::kTwoMovingRobots);
    test::write_plane_model(*dir_ / "scene.yaml", *dir_ / "model.json");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }

  /// Every output type (all on this machine: loopback addresses, a multicast group sent out of
  /// lo, a DDS domain of its own on lo) and the web view.
  void write_config(std::uint16_t udp_port, int fps = 4) {
    if (sub_port_ == 0) {  // chosen once: a rewritten config changes only what the caller asks
      sub_port_ = test::free_udp_port();
      for (auto& p : other_ports_) p = test::free_udp_port();
      web_port_ = support::free_loopback_port(SOCK_STREAM);
    }
    std::string c = "cameras:\n";
    for (const char* name : {"red", "white", "black"})
      c += std::string("  - {name: ") + name + ", source: synthetic, scene: scene.yaml, fps: " + std::to_string(fps) +
           "}\n";
    c += "markers:\n  ids:\n    1: {name: robot1, height: 0.15}\n    2: {height: 0.10}\n";
    c += "model_file: model.json\n";
    c += "fusion: {method: mean, window: 0.02, max_wait: 0.5}\n";
    c += "outputs:\n";
    c += "  - {type: unicast, address: 127.0.0.1, port: " + std::to_string(udp_port) + "}\n";
    c += "  - {type: broadcast, address: 127.255.255.255, port: " + std::to_string(other_ports_[0]) + "}\n";
    c += "  - {type: multicast, address: 239.255.42.99, port: " + std::to_string(other_ports_[1]) +
         ", ttl: 0, interface: 127.0.0.1, format: json}\n";
    c += "  - {type: mavlink, address: 127.0.0.1, port: " + std::to_string(other_ports_[2]) +
         ", vehicles: [{marker: 1, system_id: 7}]}\n";
    c += "  - {type: subscriptions, address: 127.0.0.1, port: " + std::to_string(sub_port_) +
         ", allow: [127.0.0.1/32]}\n";
    c += "  - {type: ros2, domain: " + std::to_string(kDomain) + "}\n";
    c += "web: {listen: \"127.0.0.1:" + std::to_string(web_port_) + "\", floor: [0, 0, 4.88, 4.88]}\n";
    c += "status: {interval: 0, socket: " + socket().string() + "}\n";
    if (ranging_port_ == 0) ranging_port_ = test::free_udp_port();
    c += "ranging: {port: " + std::to_string(ranging_port_) +
         ", address: 127.0.0.1, height: 0.1, anchors: [{id: 1, x: 0, y: 0, z: 2.5}, {id: 2, x: 4, y: 0, z: 1}, "
         "{id: 3, x: 4, y: 4, z: 2.5}], tags: [{id: 7, marker: 20}]}\n";
    std::ofstream(config()) << c;
  }
  static fs::path config() { return *dir_ / "ipsd.yaml"; }
  static fs::path socket() { return *dir_ / "status.sock"; }
  /// The daemon's log so far.
  std::string log() const { return test::read_file(log_); }
  /// Waits until the log holds `needle` `times` times (the daemon must stay alive meanwhile).
  bool wait_for_log(pid_t pid, const std::string& needle, int times, double seconds) const {
    return test::wait_until(
               [&] {
                 return count(log(), needle) >= times || test::wait_exit(pid, std::chrono::milliseconds(0)).has_value();
               },
               seconds * test::kTimeScale) &&
           count(log(), needle) >= times;
  }
  /// Datagrams that reach `rx` within `seconds`.
  static int datagrams(test::UdpReceiver& rx, double seconds) {
    int n = 0;
    const std::int64_t end = monotonic_ns() + static_cast<std::int64_t>(seconds * 1e9 * test::kTimeScale);
    while (monotonic_ns() < end)
      if (rx.receive(50)) ++n;
    return n;
  }

  static fs::path* dir_;
  fs::path log_ =
      *dir_ / ("ipsd_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".log");
  std::uint16_t sub_port_ = 0;
  std::array<std::uint16_t, 3> other_ports_{};  // broadcast, multicast, mavlink
  int web_port_ = 0;
  std::uint16_t ranging_port_ = 0;  // the range input's; a test may change it before a reload
};
fs::path* DaemonSignalsTest::dir_ = nullptr;

TEST_F(DaemonSignalsTest, ReloadsTwiceKeepingItsSubscribersThenStopsWithExitZero) {
  test::UdpReceiver rx;
  write_config(rx.port);
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", config().string()}, log_);
  const test::ChildGuard guard(pid);
  ASSERT_TRUE(wait_for_log(pid, "running:", 1, 60)) << log();
  ASSERT_GT(datagrams(rx, 2), 0) << log();

  // A subscriber for the whole run: the reloads (outputs unchanged) must not drop it.
  const fs::path listen_log = *dir_ / "listen.log";
  const pid_t listener =
      test::spawn({test::bin("ips"), "listen", "--subscribe", "127.0.0.1:" + std::to_string(sub_port_), "--json",
                   "--lease", "30", "--duration", std::to_string(20 * test::kTimeScale)},
                  listen_log);
  const test::ChildGuard listener_guard(listener);
  ASSERT_TRUE(test::wait_until([&] { return test::read_file(listen_log).find("subscribed at") != std::string::npos; },
                               10 * test::kTimeScale))
      << test::read_file(listen_log);

  for (int reload = 1; reload <= 2; ++reload) {
    if (reload == 2) {  // the second moves the range input to another port
      ranging_port_ = test::free_udp_port();
      write_config(rx.port);
    }
    ASSERT_EQ(::kill(pid, SIGHUP), 0);
    ASSERT_TRUE(wait_for_log(pid, "reload: applied", reload, 30)) << "reload " << reload << ":\n" << log();
    EXPECT_FALSE(test::wait_exit(pid, std::chrono::milliseconds(0))) << "ipsd died at reload " << reload << ":\n"
                                                                     << log();
    EXPECT_GT(datagrams(rx, 1.5), 0) << "no stream after reload " << reload << ":\n" << log();
  }
  // Both reloads kept the subscriptions output and its lease table: the subscriber is still there
  // and was added once (a dropped one would be logged as subscribed again at its renewal).
  const auto status = nlohmann::json::parse(test::read_unix_socket(socket().string()));
  ASSERT_EQ(status["outputs"].size(), 6u) << status.dump();
  EXPECT_EQ(status["outputs"][4].value("subscribers", 0), 1) << status.dump();
  EXPECT_EQ(count(log(), " subscribed ("), 1) << log();
  EXPECT_EQ(status["ranging"].value("port", 0), ranging_port_) << status.dump();
  EXPECT_EQ(count(log(), "reload: ranging input reopened on port " + std::to_string(ranging_port_)), 1) << log();
  const std::size_t listened = test::read_file(listen_log).size();
  EXPECT_TRUE(test::wait_until([&] { return test::read_file(listen_log).size() > listened; }, 5 * test::kTimeScale))
      << "the subscriber got nothing after the reloads:\n"
      << test::read_file(listen_log);

  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  EXPECT_EQ(test::wait_exit(pid, std::chrono::seconds(static_cast<int>(15 * test::kTimeScale))), 0) << log();
  const std::string text = log();
  EXPECT_EQ(count(text, "SIGHUP: reloading"), 2) << text;
  EXPECT_NE(text.find("Terminated: stopping"), std::string::npos) << text;
  EXPECT_NE(text.find("stopped"), std::string::npos) << text;
}

/// Every thread of `pid` blocks SIGHUP, SIGINT and SIGTERM; `when` names the moment in messages.
void expect_every_thread_blocks_the_daemon_signals(pid_t pid, const std::string& when) {
  const std::uint64_t wanted = (1ULL << (SIGHUP - 1)) | (1ULL << (SIGINT - 1)) | (1ULL << (SIGTERM - 1));
  const auto masks = blocked_masks(pid);
  // The main thread, three cameras, fusion, DDS's own threads and the web server's: many.
  EXPECT_GE(masks.size(), 8u) << when;
  std::set<std::string> names;
  for (const auto& [tid, mask] : masks) {
    names.insert(thread_name(pid, tid));
    EXPECT_EQ(mask & wanted, wanted) << when << ": thread " << tid << " (" << thread_name(pid, tid) << ") has SigBlk "
                                     << std::hex << mask;
  }
  // Cyclone DDS started threads of its own (the kind that once took SIGHUP) and they were checked.
  EXPECT_TRUE(std::any_of(names.begin(), names.end(),
                          [](const std::string& n) { return n == "gc" || n == "tev" || n.rfind("recv", 0) == 0; }))
      << when << ": no Cyclone DDS thread among the checked ones";
}

TEST_F(DaemonSignalsTest, EveryThreadBlocksTheSignalsTheDaemonReads) {
  test::UdpReceiver rx;
  write_config(rx.port);
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", config().string()}, log_);
  const test::ChildGuard guard(pid);
  ASSERT_TRUE(wait_for_log(pid, "running:", 1, 60)) << log();
  ASSERT_GT(datagrams(rx, 1), 0) << log();
  expect_every_thread_blocks_the_daemon_signals(pid, "after the start");

  // A reload that changes the cameras starts new camera threads: check after one.
  write_config(rx.port, 5);
  ASSERT_EQ(::kill(pid, SIGHUP), 0);
  ASSERT_TRUE(wait_for_log(pid, "restarting the camera threads", 1, 30)) << log();
  ASSERT_GT(datagrams(rx, 2), 0) << log();
  expect_every_thread_blocks_the_daemon_signals(pid, "after a reload that restarted the cameras");

  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  EXPECT_EQ(test::wait_exit(pid, std::chrono::seconds(static_cast<int>(15 * test::kTimeScale))), 0) << log();
}

}  // namespace
}  // namespace ips
