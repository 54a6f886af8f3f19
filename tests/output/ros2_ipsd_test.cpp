// The real ipsd on three synthetic cameras with a ros2 output (and a UDP output beside it),
// received over the loopback network by a subscriber written here with the Cyclone DDS C API:
// the samples carry exactly the UDP stream's values and the simulator's truth, and the DDS
// built-in publication topic shows exactly the topic and type names ROS 2 expects.
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "ips/sim/scene.h"
#include "plane_model.h"
#include "process_util.h"
#include "published_scene.h"
#include "ros2_test_util.h"

namespace ips {
namespace {

namespace fs = std::filesystem;
using PoseStamped = geometry_msgs_msg_dds__PoseStamped_;
using Odometry = nav_msgs_msg_dds__Odometry_;
using TFMessage = tf2_msgs_msg_dds__TFMessage_;

constexpr int kDomain = 64;
constexpr double kFps = 4.0;

class Ros2IpsdTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    test::use_loopback_dds();
    dir_ = new fs::path(fs::temp_directory_path() / ("ros2_ipsd_test_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    std::ofstream(*dir_ / "scene.yaml") << test::published_scene_with(test::kTwoMovingRobots);
    test::write_plane_model(*dir_ / "scene.yaml", *dir_ / "model.json");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }

  static std::string config(std::uint16_t udp_port, const std::string& ros2) {
    std::string c = "cameras:\n";
    for (const char* name : {"red", "white", "black"})
      c += std::string("  - {name: ") + name + ", source: synthetic, scene: scene.yaml, fps: " + std::to_string(kFps) +
           "}\n";
    c += "markers:\n  ids:\n    1: {name: robot1, height: 0.15}\n    2: {height: 0.10}\n";
    c += "model_file: model.json\n";
    c += "fusion: {method: mean, window: 0.02, max_wait: 0.5, kalman: {enabled: true}}\n";
    c += "outputs:\n  - {type: unicast, address: 127.0.0.1, port: " + std::to_string(udp_port) + "}\n";
    c += "  - " + ros2 + "\n";
    c += "status: {interval: 2, socket: " + (*dir_ / "status.sock").string() + "}\n";
    return c;
  }

  static fs::path* dir_;
};
fs::path* Ros2IpsdTest::dir_ = nullptr;

std::int64_t ns(const builtin_interfaces_msg_dds__Time_& t) { return 1'000'000'000LL * t.sec + t.nanosec; }

struct UdpMarker {
  MarkerRecord m;
  std::int64_t capture_mono_ns;  // of this marker
};

TEST_F(Ros2IpsdTest, RosSubscriberGetsTheDaemonsStreamUnderRos2Names) {
  test::DdsParticipant p(kDomain);
  const auto pose1 = test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/ipsd/robot1/pose", false);
  const auto odom2 = test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/ipsd/marker_2/odom", false);
  const auto tf = test::make_reader(p, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", true);
  const auto pubs = dds_create_reader(p.id, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  ASSERT_GT(pubs, 0);

  test::UdpReceiver rx;
  const fs::path cfg = *dir_ / "ipsd.yaml";
  std::ofstream(cfg) << config(rx.port, "{type: ros2, domain: " + std::to_string(kDomain) + ", tf: true}");
  const fs::path log = *dir_ / "ipsd.log";
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", cfg.string()}, log);
  const test::ChildGuard guard(pid);

  // (id, realtime stamp) -> the UDP records: the ROS samples are looked up by their stamp. One
  // capture instant can give several updates (one per camera frame of that instant, each fusing
  // more of them), so a stamp may hold several records.
  std::map<std::pair<std::uint32_t, std::int64_t>, std::vector<UdpMarker>> udp;
  std::vector<PoseStamped> poses;
  std::vector<Odometry> odoms;
  std::vector<std::vector<std::string>> tf_children;
  std::map<std::string, std::string> published;  // DDS topic -> type, from DCPSPublication
  std::map<std::string, dds_reliability_kind_t> reliability;
  const bool enough = test::wait_until(
      [&] {
        while (auto bytes = rx.receive(0)) {
          const Datagram d = decode_datagram(*bytes);
          for (const auto& m : d.markers)
            udp[{m.id, d.capture_realtime_ns + 1000LL * m.dt_us}].push_back(
                {m, d.capture_monotonic_ns + 1000LL * m.dt_us});
        }
        test::take_all<PoseStamped>(pose1, [&](const PoseStamped& m) {
          poses.push_back(m);
          poses.back().header.frame_id = nullptr;  // the loaned string is gone after the take
          EXPECT_STREQ(m.header.frame_id, "world");
        });
        test::take_all<Odometry>(odom2, [&](const Odometry& m) {
          odoms.push_back(m);
          odoms.back().header.frame_id = odoms.back().child_frame_id = nullptr;
          EXPECT_STREQ(m.child_frame_id, "marker_2");
        });
        test::take_all<TFMessage>(tf, [&](const TFMessage& m) {
          std::vector<std::string> children;
          for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
            children.push_back(m.transforms._buffer[i].child_frame_id);
            EXPECT_STREQ(m.transforms._buffer[i].header.frame_id, "world");
          }
          tf_children.push_back(children);
        });
        test::take_all<dds_builtintopic_endpoint_t>(pubs, [&](const dds_builtintopic_endpoint_t& e) {
          published[e.topic_name] = e.type_name;
          dds_reliability_kind_t kind;
          dds_duration_t blocking;
          if (dds_qget_reliability(e.qos, &kind, &blocking)) reliability[e.topic_name] = kind;
        });
        return poses.size() >= 12 && odoms.size() >= 4 && tf_children.size() >= 4 && published.size() >= 5;
      },
      60.0 * test::kTimeScale);
  ASSERT_TRUE(enough) << poses.size() << " poses, " << odoms.size() << " odometry, " << tf_children.size() << " tf, "
                      << published.size() << " publications\n"
                      << test::read_file(log);

  // Exactly the ROS 2 names: rt/ + the ROS topic, types as rosidl registers them in DDS.
  const std::map<std::string, std::string> expected = {
      {"rt/ipsd/robot1/pose", "geometry_msgs::msg::dds_::PoseStamped_"},
      {"rt/ipsd/robot1/odom", "nav_msgs::msg::dds_::Odometry_"},
      {"rt/ipsd/marker_2/pose", "geometry_msgs::msg::dds_::PoseStamped_"},
      {"rt/ipsd/marker_2/odom", "nav_msgs::msg::dds_::Odometry_"},
      {"rt/tf", "tf2_msgs::msg::dds_::TFMessage_"},
  };
  EXPECT_EQ(published, expected);
  EXPECT_EQ(reliability["rt/ipsd/robot1/pose"], DDS_RELIABILITY_BEST_EFFORT);  // qos default
  EXPECT_EQ(reliability["rt/tf"], DDS_RELIABILITY_RELIABLE);                   // what tf2 listeners ask for

  const auto status = nlohmann::json::parse(test::read_unix_socket((*dir_ / "status.sock").string()));
  const std::int64_t epoch = status["synthetic_epoch_mono_ns"];
  const auto scene = sim::Scene::load(*dir_ / "scene.yaml");

  // PoseStamped of robot1: the very UDP record with that capture stamp, and the truth.
  int matched = 0;
  for (const auto& ps : poses) {
    const auto it = udp.find({1u, ns(ps.header.stamp)});
    if (it == udp.end()) continue;  // its datagram is still on the way
    ++matched;
    // The binary UDP stream carries float32 of the same doubles ROS gets: one of the records
    // with this stamp is the same update.
    const UdpMarker* same = nullptr;
    for (const UdpMarker& u : it->second)
      if (static_cast<float>(ps.pose.position.x) == static_cast<float>(u.m.x) &&
          static_cast<float>(ps.pose.position.y) == static_cast<float>(u.m.y) &&
          static_cast<float>(ps.pose.position.z) == static_cast<float>(u.m.z))
        same = &u;
    ASSERT_NE(same, nullptr) << "no UDP record at stamp " << ns(ps.header.stamp) << " has (" << ps.pose.position.x
                             << ", " << ps.pose.position.y << ")";
    const MarkerRecord& m = same->m;
    EXPECT_NEAR(ps.pose.orientation.z, std::sin(m.yaw / 2), 1e-6);
    EXPECT_NEAR(ps.pose.orientation.w, std::cos(m.yaw / 2), 1e-6);
    const double t = 1e-9 * static_cast<double>(same->capture_mono_ns - epoch);
    const sim::MarkerPose truth = scene.marker_pose(1, t);
    EXPECT_LT(std::hypot(ps.pose.position.x - truth.x, ps.pose.position.y - truth.y), 0.02) << "t " << t;
    EXPECT_NEAR(ps.pose.position.z, 0.15, 1e-6);
  }
  EXPECT_GE(matched, static_cast<int>(poses.size()) - 2);

  // Odometry of the unnamed marker 2: the UDP velocity in the robot's own frame; the line
  // trajectory's speed is 0.25 m/s.
  int with_speed = 0;
  for (const auto& od : odoms) {
    const auto it = udp.find({2u, ns(od.header.stamp)});
    if (it == udp.end()) continue;
    const UdpMarker* same = nullptr;
    for (const UdpMarker& u : it->second)
      if (static_cast<float>(od.pose.pose.position.x) == static_cast<float>(u.m.x) &&
          static_cast<float>(od.pose.pose.position.y) == static_cast<float>(u.m.y))
        same = &u;
    ASSERT_NE(same, nullptr) << "no UDP record at stamp " << ns(od.header.stamp);
    const MarkerRecord& m = same->m;
    const double c = std::cos(m.yaw), s = std::sin(m.yaw);  // float32 inputs: compare to 1e-5
    EXPECT_NEAR(od.twist.twist.linear.x, c * m.vx + s * m.vy, 1e-5);
    EXPECT_NEAR(od.twist.twist.linear.y, -s * m.vx + c * m.vy, 1e-5);
    EXPECT_NEAR(od.twist.twist.linear.z, m.vz, 1e-6);
    with_speed += std::abs(std::hypot(od.twist.twist.linear.x, od.twist.twist.linear.y) - 0.25) < 0.1;
  }
  EXPECT_GE(with_speed, 1);

  // /tf: one message per update, the markers it holds as child frames.
  std::set<std::string> children;
  for (const auto& c : tf_children) children.insert(c.begin(), c.end());
  EXPECT_EQ(children, (std::set<std::string>{"robot1", "marker_2"}));
}

TEST_F(Ros2IpsdTest, BadRos2ConfigurationExitsWith2NamingTheKey) {
  const std::map<std::string, std::string> cases = {
      {"{type: ros2, qos: fast}", "outputs[1].qos: unknown value 'fast'"},
      {"{type: ros2, domain: 233}", "outputs[1].domain: must be 0..232"},
      {"{type: ros2, prefix: ''}", "outputs[1].prefix: empty"},
  };
  for (const auto& [output, message] : cases) {
    const fs::path cfg = *dir_ / "bad.yaml";
    std::ofstream(cfg) << config(9, output);
    const fs::path log = *dir_ / "bad.log";
    fs::remove(log);
    EXPECT_EQ(test::run({test::bin("ipsd"), "--check", "--config", cfg.string()}, log), 2) << output;
    EXPECT_NE(test::read_file(log).find(message), std::string::npos) << test::read_file(log);
  }
}

}  // namespace
}  // namespace ips
