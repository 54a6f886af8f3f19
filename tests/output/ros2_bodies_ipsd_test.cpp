// The real ipsd with rigid bodies and a ros2 output, received over loopback by a subscriber
// written here with the Cyclone DDS C API: every body PoseStamped is one of the daemon's own
// UDP body records (same capture stamp, same pose, same quaternion) and near the simulator's
// body truth, the bodies' frames are on /tf beside the plain marker's, and their Odometry
// carries the truth's velocity and yaw rate in the body frame.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "bodies_lab_scene.h"
#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
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
using Odometry = nav_msgs_msg_dds__Odometry_;

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

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
  const std::map<std::string, dds_entity_t> odom_readers = {
      {"turtle", test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/ipsd/turtle/odom", false)},
      {"long", test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/ipsd/long/odom", false)}};

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
  std::map<std::string, std::vector<Odometry>> odoms;
  std::set<std::string> tf_children;
  const bool enough = test::wait_until(
      [&] {
        while (auto bytes = rx.receive(0)) {
          const Datagram d = decode_datagram(*bytes);
          for (const auto& b : d.bodies)
            udp[{b.name, d.capture_realtime_ns + 1000LL * b.dt_us}].push_back(
                {b, d.capture_monotonic_ns + 1000LL * b.dt_us});
        }
        for (const auto& [name, reader] : readers)
          test::take_all<PoseStamped>(reader, [&, n = name](const PoseStamped& m) {
            EXPECT_STREQ(m.header.frame_id, "world");
            poses[n].push_back(m);
            poses[n].back().header.frame_id = nullptr;  // the loaned string is gone after the take
          });
        for (const auto& [name, reader] : odom_readers)
          test::take_all<Odometry>(reader, [&, n = name](const Odometry& m) {
            odoms[n].push_back(m);
            odoms[n].back().header.frame_id = odoms[n].back().child_frame_id = nullptr;
          });
        test::take_all<TFMessage>(tf, [&](const TFMessage& m) {
          for (std::uint32_t i = 0; i < m.transforms._length; ++i)
            tf_children.insert(m.transforms._buffer[i].child_frame_id);
        });
        return poses["turtle"].size() >= 10 && poses["long"].size() >= 10 && odoms["turtle"].size() >= 10 &&
               odoms["long"].size() >= 10 && tf_children.size() >= 3;
      },
      60.0);
  ASSERT_TRUE(enough) << poses["turtle"].size() << " turtle, " << poses["long"].size() << " long, "
                      << odoms["turtle"].size() << " / " << odoms["long"].size() << " odom, " << tf_children.size()
                      << " tf frames\n"
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
  // Odometry: the twist in the body frame against the truth's derivatives at the same instant
  // (the daemon's are means over fusion.velocity_span, 0.2 s: IpsdBodies bounds their p95).
  for (const auto& [name, samples] : odoms) {
    const std::size_t index = name == "turtle" ? 0 : 1;
    std::vector<double> linear, angular;
    for (const Odometry& od : samples) {
      const auto it = udp.find({name, ns(od.header.stamp)});
      if (it == udp.end()) continue;
      const double t = 1e-9 * static_cast<double>(it->second.front().mono_ns - epoch), h = 1e-3;
      const BodyPose a = scene.body_pose_at(index, t - h), b = scene.body_pose_at(index, t + h),
                     c = scene.body_pose_at(index, t);
      const Eigen::Vector3d v = c.q.conjugate() * ((b.position - a.position) / (2 * h));
      const auto& tw = od.twist.twist;
      linear.push_back(std::hypot(tw.linear.x - v.x(), tw.linear.y - v.y()));
      angular.push_back(std::abs(tw.angular.z - std::remainder(b.yaw - a.yaw, 2 * std::numbers::pi) / (2 * h)));
    }
    std::printf("[ ros2    ] %s odometry: %zu matched, twist error median %.1f mm/s, %.2f deg/s\n", name.c_str(),
                linear.size(), 1e3 * median(linear), median(angular) * 180 / std::numbers::pi);
    ASSERT_GE(linear.size(), 5u) << name;
    EXPECT_LT(median(linear), 0.03) << name;   // the robot drives forward at 0.5 m/s
    EXPECT_LT(median(angular), 0.05) << name;  // turning at 0.256 rad/s
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips
