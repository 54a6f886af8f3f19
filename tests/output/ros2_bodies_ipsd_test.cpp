// The real ipsd with rigid bodies and a ros2 output, received over loopback by a subscriber
// written here with the Cyclone DDS C API: every body PoseStamped is one of the daemon's own
// UDP body records (same capture stamp, same pose, same quaternion) and near the simulator's
// body truth, and the bodies' frames are on /tf beside the plain marker's.
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "bodies_lab_scene.h"
#include "ips/clock.h"
#include "ips/packet_codec.h"
#include "ips/sim/scene.h"
#include "plane_model.h"
#include "process_util.h"
#include "release_only.h"
#include "ros2_test_util.h"

namespace ips {
namespace {

namespace fs = std::filesystem;
using PoseStamped = geometry_msgs_msg_dds__PoseStamped_;
using TFMessage = tf2_msgs_msg_dds__TFMessage_;

constexpr int kDomain = 65;

std::int64_t ns(const builtin_interfaces_msg_dds__Time_& t) { return 1'000'000'000LL * t.sec + t.nanosec; }

TEST(Ros2IpsdBodies, BodyPosesAreTheStreamsBodyRecordsWithTheirQuaternion) {
  // Three rendering cameras for several seconds: CPU-bound, as IpsdBodies.*.
  IPS_RELEASE_ONLY("Ros2SinkTest.BodiesGetTheirFullOrientationOnPoseAndTf (the sink) and IpsdBodies.* (the daemon)");
  test::use_loopback_dds();
  const fs::path dir = fs::temp_directory_path() / ("ros2_bodies_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "scene.yaml") << test::bodies_lab_scene();
  test::write_plane_model(dir / "scene.yaml", dir / "model.json");

  test::DdsParticipant p(kDomain);
  const std::map<std::string, dds_entity_t> readers = {
      {"turtle", test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/ipsd/turtle/pose", false)},
      {"long", test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/ipsd/long/pose", false)}};
  const auto tf = test::make_reader(p, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", true);

  test::UdpReceiver rx;
  std::string cfg = "cameras:\n";
  for (const char* name : {"red", "white", "black"})
    cfg += std::string("  - {name: ") + name + ", source: synthetic, scene: scene.yaml, fps: 10}\n";
  cfg += test::bodies_lab_daemon_sections();
  cfg += "model_file: model.json\noutputs:\n  - {type: unicast, address: 127.0.0.1, port: " + std::to_string(rx.port) +
         ", format: binary}\n  - {type: ros2, domain: " + std::to_string(kDomain) + ", tf: true}\n";
  std::ofstream(dir / "ipsd.yaml") << cfg;
  const fs::path log = dir / "ipsd.log";
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", (dir / "ipsd.yaml").string()}, log);
  const test::ChildGuard guard(pid);

  struct Udp {
    BodyRecord b;
    std::int64_t mono_ns;
  };
  std::map<std::pair<std::string, std::int64_t>, std::vector<Udp>> udp;  // (name, realtime stamp)
  std::map<std::string, std::vector<PoseStamped>> poses;
  std::set<std::string> tf_children;
  const bool enough = test::wait_until(
      [&] {
        while (auto bytes = rx.receive(0)) {
          const Datagram d = decode_datagram(*bytes);
          for (const auto& b : d.bodies)
            udp[{b.name, d.capture_realtime_ns + 1000LL * b.dt_us}].push_back({b, d.capture_monotonic_ns + 1000LL * b.dt_us});
        }
        for (const auto& [name, reader] : readers)
          test::take_all<PoseStamped>(reader, [&, n = name](const PoseStamped& m) {
            EXPECT_STREQ(m.header.frame_id, "world");
            poses[n].push_back(m);
            poses[n].back().header.frame_id = nullptr;  // the loaned string is gone after the take
          });
        test::take_all<TFMessage>(tf, [&](const TFMessage& m) {
          for (std::uint32_t i = 0; i < m.transforms._length; ++i) tf_children.insert(m.transforms._buffer[i].child_frame_id);
        });
        return poses["turtle"].size() >= 10 && poses["long"].size() >= 10 && tf_children.size() >= 3;
      },
      60.0);
  ASSERT_TRUE(enough) << poses["turtle"].size() << " turtle, " << poses["long"].size() << " long, "
                      << tf_children.size() << " tf frames\n"
                      << test::read_file(log);
  EXPECT_EQ(tf_children, (std::set<std::string>{"turtle", "long", "marker_3"}));

  const std::string text = test::read_file(log);
  const auto at = text.find("scene time 0 = CLOCK_MONOTONIC ");
  ASSERT_NE(at, std::string::npos) << text;
  const std::int64_t epoch = std::stoll(text.substr(at + 31));
  const auto scene = sim::Scene::load(dir / "scene.yaml");
  for (const auto& [name, samples] : poses) {
    const std::size_t index = name == "turtle" ? 0 : 1;
    ASSERT_EQ(scene.bodies[index].def.name, name);
    int matched = 0;
    for (const PoseStamped& ps : samples) {
      const auto it = udp.find({name, ns(ps.header.stamp)});
      if (it == udp.end()) continue;  // its datagram is still on the way
      // The binary stream carries float32 of the doubles ROS gets.
      const Udp* same = nullptr;
      for (const Udp& u : it->second)
        if (static_cast<float>(ps.pose.position.x) == static_cast<float>(u.b.x) &&
            static_cast<float>(ps.pose.position.y) == static_cast<float>(u.b.y) &&
            static_cast<float>(ps.pose.position.z) == static_cast<float>(u.b.z))
          same = &u;
      ASSERT_NE(same, nullptr) << name << ": no UDP body record at stamp " << ns(ps.header.stamp);
      ++matched;
      EXPECT_TRUE(same->b.has_yaw) << "a position-only body update reached ROS";
      const auto& q = ps.pose.orientation;
      EXPECT_EQ(static_cast<float>(q.w), static_cast<float>(same->b.qw));
      EXPECT_EQ(static_cast<float>(q.x), static_cast<float>(same->b.qx));
      EXPECT_EQ(static_cast<float>(q.y), static_cast<float>(same->b.qy));
      EXPECT_EQ(static_cast<float>(q.z), static_cast<float>(same->b.qz));
      EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-6);
      // And the simulator's truth (IpsdBodies bounds the p95 at 1.5 cm and 2 degrees; each
      // sample here within 3 cm and 5 degrees).
      const BodyPose truth = scene.body_pose_at(index, 1e-9 * static_cast<double>(same->mono_ns - epoch));
      EXPECT_LT(std::hypot(ps.pose.position.x - truth.position.x(), ps.pose.position.y - truth.position.y()), 0.03)
          << name;
      const Eigen::Quaterniond got(q.w, q.x, q.y, q.z);
      EXPECT_LT(got.angularDistance(truth.q) * 180 / std::numbers::pi, 5.0) << name;
    }
    EXPECT_GE(matched, static_cast<int>(samples.size()) - 2) << name;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips
