// The ros2 output in process: a subscriber written against the Cyclone DDS C API receives the
// sink's PoseStamped / Odometry / TFMessage samples (of markers and bodies), compared field by field with values
// computed here by hand. (tests/output/ros2_ipsd_test.cpp runs the real daemon over the network.)
#include <cmath>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "output/ros2_names.h"
#include "output/ros2_sink.h"
#include "ros2_test_util.h"

namespace ips {
namespace {

using PoseStamped = geometry_msgs_msg_dds__PoseStamped_;
using Odometry = nav_msgs_msg_dds__Odometry_;
using TFMessage = tf2_msgs_msg_dds__TFMessage_;

// Each test its own domain, so that none sees another's writers.
constexpr int kDomainValues = 61, kDomainNoVelocity = 62, kDomainAccounting = 63, kDomainBodies = 60;

class Ros2SinkTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { test::use_loopback_dds(); }
};

OutputConfig ros2_output(int domain) {
  OutputConfig o;
  o.kind = OutputConfig::Kind::kRos2;
  o.ros2.domain = domain;
  o.ros2.prefix = "lab/ipsd";
  o.ros2.marker_names = {{7, "robot1"}};
  return o;
}

// Capture 1700000000.123456789 s; marker 7 seen 250 us earlier, marker 9 100 us later.
Datagram update(bool velocity) {
  Datagram d;
  d.has_velocity = velocity;
  d.capture_realtime_ns = 1'700'000'000'123'456'789;
  MarkerRecord a;
  a.id = 7;
  a.x = 1.25, a.y = -2.5, a.z = 0.125;
  a.yaw = M_PI / 2;
  a.dt_us = -250;
  a.vx = 1.0, a.vy = 0.0, a.vz = 0.5;
  a.covariance = {1e-4, 2e-5, 3e-6, 4e-4, 5e-6, 9e-4};
  a.has_yaw = false;  // held (ranges alone): the odometry's yaw variance says so
  MarkerRecord b;
  b.id = 9;
  b.x = 3.0, b.y = 4.0, b.z = 0.0;
  b.yaw = -M_PI / 3;
  b.dt_us = 100;
  b.vx = 0.0, b.vy = 2.0;
  d.markers = {a, b};
  return d;
}

TEST_F(Ros2SinkTest, SubscriberReceivesPoseOdometryAndTfWithTheRightValues) {
  OutputConfig o = ros2_output(kDomainValues);
  o.ros2.frame_id = "map";
  o.ros2.child_frame_id = "{name}_base";
  o.ros2.tf = true;
  o.ros2.reliable = true;
  test::DdsParticipant p(kDomainValues);
  const auto pose7 = test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/lab/ipsd/robot1/pose", true);
  const auto pose9 = test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/lab/ipsd/marker_9/pose", true);
  const auto odom7 = test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/lab/ipsd/robot1/odom", true);
  const auto tf = test::make_reader(p, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", true);

  Ros2Sink sink(o, "outputs[0]");
  std::vector<PoseStamped> p7, p9;
  std::vector<Odometry> o7;
  int tf_messages = 0;
  // Writers are created on a marker's first update: publish until every reader has data.
  ASSERT_TRUE(test::wait_until(
      [&] {
        sink.publish(update(true));
        // Strings are checked inside: the loaned sample's strings are gone after the take.
        test::take_all<PoseStamped>(pose7, [&](const PoseStamped& m) {
          EXPECT_STREQ(m.header.frame_id, "map");
          p7.push_back(m);
          p7.back().header.frame_id = nullptr;
        });
        test::take_all<PoseStamped>(pose9, [&](const PoseStamped& m) {
          p9.push_back(m);
          p9.back().header.frame_id = nullptr;
        });
        test::take_all<Odometry>(odom7, [&](const Odometry& m) {
          o7.push_back(m);
          o7.back().header.frame_id = o7.back().child_frame_id = nullptr;
          EXPECT_STREQ(m.header.frame_id, "map");
          EXPECT_STREQ(m.child_frame_id, "robot1_base");
        });
        tf_messages += test::take_all<TFMessage>(tf, [&](const TFMessage& m) {
          // One TFMessage per update, one transform per marker, in the update's order.
          ASSERT_EQ(m.transforms._length, 2u);
          const auto& t7 = m.transforms._buffer[0];
          const auto& t9 = m.transforms._buffer[1];
          EXPECT_STREQ(t7.header.frame_id, "map");
          EXPECT_STREQ(t7.child_frame_id, "robot1_base");
          EXPECT_STREQ(t9.child_frame_id, "marker_9_base");
          EXPECT_EQ(t7.header.stamp.sec, 1'700'000'000);
          EXPECT_EQ(t7.header.stamp.nanosec, 123'206'789u);
          EXPECT_EQ(t9.header.stamp.nanosec, 123'556'789u);
          EXPECT_DOUBLE_EQ(t7.transform.translation.x, 1.25);
          EXPECT_DOUBLE_EQ(t7.transform.translation.y, -2.5);
          EXPECT_DOUBLE_EQ(t7.transform.translation.z, 0.125);
          EXPECT_NEAR(t7.transform.rotation.z, std::sqrt(0.5), 1e-12);
          EXPECT_NEAR(t7.transform.rotation.w, std::sqrt(0.5), 1e-12);
          EXPECT_NEAR(t9.transform.rotation.z, -0.5, 1e-12);  // yaw -60 deg: sin(-30 deg)
          EXPECT_NEAR(t9.transform.rotation.w, std::sqrt(3.0) / 2, 1e-12);
        });
        return !p7.empty() && !p9.empty() && !o7.empty() && tf_messages > 0;
      },
      10.0))
      << p7.size() << " " << p9.size() << " " << o7.size() << " " << tf_messages;

  // PoseStamped of marker 7: stamp = capture - 250 us, frame "map", yaw 90 deg about z.
  const PoseStamped& a = p7.front();
  EXPECT_EQ(a.header.stamp.sec, 1'700'000'000);
  EXPECT_EQ(a.header.stamp.nanosec, 123'206'789u);
  EXPECT_DOUBLE_EQ(a.pose.position.x, 1.25);
  EXPECT_DOUBLE_EQ(a.pose.position.y, -2.5);
  EXPECT_DOUBLE_EQ(a.pose.position.z, 0.125);
  EXPECT_DOUBLE_EQ(a.pose.orientation.x, 0.0);
  EXPECT_DOUBLE_EQ(a.pose.orientation.y, 0.0);
  EXPECT_NEAR(a.pose.orientation.z, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(a.pose.orientation.w, std::sqrt(0.5), 1e-12);
  // Marker 9, unnamed: its own topic, stamp = capture + 100 us.
  const PoseStamped& b = p9.front();
  EXPECT_EQ(b.header.stamp.nanosec, 123'556'789u);
  EXPECT_DOUBLE_EQ(b.pose.position.x, 3.0);
  EXPECT_DOUBLE_EQ(b.pose.position.y, 4.0);
  // Odometry: same pose; the world velocity (1, 0, 0.5) seen by a robot facing +y is
  // (0, -1, 0.5) in its own frame (nav_msgs/Odometry: twist in child_frame_id).
  const Odometry& od = o7.front();
  EXPECT_EQ(od.header.stamp.nanosec, 123'206'789u);
  EXPECT_DOUBLE_EQ(od.pose.pose.position.x, 1.25);
  EXPECT_NEAR(od.pose.pose.orientation.z, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(od.twist.twist.linear.x, 0.0, 1e-12);
  EXPECT_NEAR(od.twist.twist.linear.y, -1.0, 1e-12);
  EXPECT_NEAR(od.twist.twist.linear.z, 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(od.twist.twist.angular.z, 0.0);  // not estimated
  // Pose covariance, row-major over (x y z, rot x y z): the record's position block written
  // out by hand, the held heading's pi^2 on rot z, the rest 0.
  double want[36] = {};
  want[0] = 1e-4, want[1] = want[6] = 2e-5, want[2] = want[12] = 3e-6;
  want[7] = 4e-4, want[8] = want[13] = 5e-6, want[14] = 9e-4;
  want[35] = M_PI * M_PI;
  for (int k = 0; k < 36; ++k) EXPECT_DOUBLE_EQ(od.pose.covariance[k], want[k]) << "covariance[" << k << "]";
  const auto s = sink.stats();
  EXPECT_EQ(s.description, "ros2 domain 61 /lab/ipsd");
  EXPECT_GT(s.datagrams, 0u);
}

TEST_F(Ros2SinkTest, BodiesGetTheirFullOrientationOnPoseAndTf) {
  OutputConfig o = ros2_output(kDomainBodies);
  o.ros2.child_frame_id = "{name}_base";
  o.ros2.tf = true;
  o.ros2.reliable = true;
  test::DdsParticipant p(kDomainBodies);
  const auto cube = test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/lab/ipsd/cube/pose", true);
  const auto slab = test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/lab/ipsd/slab/pose", true);
  const auto tf = test::make_reader(p, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", true);
  const auto cube_odom = test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/lab/ipsd/cube/odom", true);
  const auto slab_odom = test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/lab/ipsd/slab/odom", true);
  // Marker 7 and two bodies: "cube" tilted 90 degrees about x (w = x = sqrt(1/2)), seen 400 us
  // before the capture time, moving at (1, 2, 0) m/s and turning at 0.5 rad/s; "slab" with a
  // position only (no orientation measured).
  Datagram d = update(false);
  d.markers.resize(1);
  BodyRecord b;
  b.name = "cube";
  b.x = 0.5, b.y = 1.5, b.z = 0.3;
  b.qw = std::sqrt(0.5), b.qx = std::sqrt(0.5), b.qy = 0.0, b.qz = 0.0;
  b.dt_us = -400;
  b.has_yaw = true;
  b.has_velocity = b.has_yaw_rate = true;
  b.vx = 1.0, b.vy = 2.0, b.vz = 0.0;
  b.yaw_rate = 0.5;
  BodyRecord position_only = b;
  position_only.name = "slab";
  position_only.has_yaw = false;
  d.bodies = {b, position_only};

  Ros2Sink sink(o, "outputs[0]");
  std::vector<PoseStamped> poses;
  std::vector<Odometry> odoms;
  int tf_messages = 0;
  ASSERT_TRUE(test::wait_until(
      [&] {
        sink.publish(d);
        test::take_all<PoseStamped>(cube, [&](const PoseStamped& m) {
          EXPECT_STREQ(m.header.frame_id, "world");
          poses.push_back(m);
          poses.back().header.frame_id = nullptr;
        });
        tf_messages += test::take_all<TFMessage>(tf, [&](const TFMessage& m) {
          // The markers' transforms first, then the bodies' with an orientation.
          ASSERT_EQ(m.transforms._length, 2u);
          const auto& t = m.transforms._buffer[1];
          EXPECT_STREQ(m.transforms._buffer[0].child_frame_id, "robot1_base");
          EXPECT_STREQ(t.child_frame_id, "cube_base");
          EXPECT_EQ(t.header.stamp.nanosec, 123'056'789u);
          EXPECT_DOUBLE_EQ(t.transform.translation.z, 0.3);
          EXPECT_DOUBLE_EQ(t.transform.rotation.x, std::sqrt(0.5));
          EXPECT_DOUBLE_EQ(t.transform.rotation.w, std::sqrt(0.5));
        });
        test::take_all<Odometry>(cube_odom, [&](const Odometry& m) {
          EXPECT_STREQ(m.child_frame_id, "cube_base");
          odoms.push_back(m);
          odoms.back().header.frame_id = odoms.back().child_frame_id = nullptr;
        });
        return !poses.empty() && tf_messages > 0 && !odoms.empty();
      },
      10.0))
      << poses.size() << " " << tf_messages << " " << odoms.size();
  const PoseStamped& a = poses.front();
  EXPECT_EQ(a.header.stamp.sec, 1'700'000'000);
  EXPECT_EQ(a.header.stamp.nanosec, 123'056'789u);  // capture - 400 us
  EXPECT_DOUBLE_EQ(a.pose.position.x, 0.5);
  EXPECT_DOUBLE_EQ(a.pose.position.y, 1.5);
  EXPECT_DOUBLE_EQ(a.pose.position.z, 0.3);
  EXPECT_DOUBLE_EQ(a.pose.orientation.x, std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(a.pose.orientation.y, 0.0);
  EXPECT_DOUBLE_EQ(a.pose.orientation.z, 0.0);
  EXPECT_DOUBLE_EQ(a.pose.orientation.w, std::sqrt(0.5));
  // Odometry: the twist in the body frame. The body's x stays world x; world y is the body's
  // -z and world z its y (Rx(90)): v (1, 2, 0) -> (1, 0, -2), yaw rate about world z -> body y.
  const Odometry& od = odoms.front();
  EXPECT_EQ(od.header.stamp.nanosec, 123'056'789u);
  EXPECT_DOUBLE_EQ(od.pose.pose.position.y, 1.5);
  EXPECT_DOUBLE_EQ(od.pose.pose.orientation.x, std::sqrt(0.5));
  EXPECT_NEAR(od.twist.twist.linear.x, 1.0, 1e-12);
  EXPECT_NEAR(od.twist.twist.linear.y, 0.0, 1e-12);
  EXPECT_NEAR(od.twist.twist.linear.z, -2.0, 1e-12);
  EXPECT_NEAR(od.twist.twist.angular.x, 0.0, 1e-12);
  EXPECT_NEAR(od.twist.twist.angular.y, 0.5, 1e-12);
  EXPECT_NEAR(od.twist.twist.angular.z, 0.0, 1e-12);
  // The position-only body was never written (a reliable reader of its topic got nothing).
  EXPECT_EQ(test::take_all<PoseStamped>(slab, [](const PoseStamped&) {}), 0);
  EXPECT_EQ(test::take_all<Odometry>(slab_odom, [](const Odometry&) {}), 0);
}

TEST_F(Ros2SinkTest, NoOdometryWithoutVelocityAndBestEffortReadersMatch) {
  const OutputConfig o = ros2_output(kDomainNoVelocity);  // best_effort, no tf
  test::DdsParticipant p(kDomainNoVelocity);
  const auto pose = test::make_reader(p, &geometry_msgs_msg_dds__PoseStamped__desc, "rt/lab/ipsd/robot1/pose", false);
  const auto odom = test::make_reader(p, &nav_msgs_msg_dds__Odometry__desc, "rt/lab/ipsd/robot1/odom", false);
  Ros2Sink sink(o, "outputs[0]");
  int poses = 0;
  ASSERT_TRUE(test::wait_until(
      [&] {
        sink.publish(update(false));
        poses += test::take_all<PoseStamped>(pose, [](const PoseStamped&) {});
        return poses >= 3;
      },
      10.0));
  // A zero twist would tell the robot it stands still: no velocity, no Odometry at all.
  EXPECT_EQ(test::take_all<Odometry>(odom, [](const Odometry&) {}), 0);
}

TEST_F(Ros2SinkTest, EveryUpdateIsWrittenOrCountedAsLost) {
  // 500 updates as fast as the caller can: publish() only fills the mailbox, so each update is
  // either written by the sink's thread (one PoseStamped) or replaced before it was (counted).
  OutputConfig o = ros2_output(kDomainAccounting);
  o.ros2.odometry = false;
  Ros2Sink sink(o, "outputs[0]");
  Datagram d = update(false);
  d.markers.resize(1);
  constexpr int kUpdates = 500;
  for (int i = 0; i < kUpdates; ++i) sink.publish(d);
  ASSERT_TRUE(test::wait_until(
      [&] {
        const auto s = sink.stats();
        return s.counters.size() == 1 && s.datagrams + s.counters[0].second == kUpdates;
      },
      10.0))
      << sink.stats().datagrams << " + replaced";
  const OutputStats s = sink.stats();
  EXPECT_EQ(s.counters[0].first, "replaced");
  EXPECT_EQ(s.send_errors, 0u) << "a replaced update is not a failed write";
  EXPECT_GE(s.datagrams, 1u);
  EXPECT_NE(sink.last_latency_ns(), 0);
}

TEST(Ros2Names, TopicsFramesStampsAndQuaternions) {
  Ros2OutputSettings s;
  s.marker_names = {{1, "robot1"}};
  EXPECT_EQ(ros2::marker_topic(s, 1, "pose"), "rt/ipsd/robot1/pose");
  EXPECT_EQ(ros2::marker_topic(s, 12, "odom"), "rt/ipsd/marker_12/odom");
  s.child_frame_id = "ips_{id}_{name}";
  EXPECT_EQ(ros2::child_frame(s, 1), "ips_1_robot1");
  EXPECT_EQ(ros2::body_child_frame(s, "cube"), "ips_cube_cube");  // a body has a name, no id
  EXPECT_EQ(ros2::body_topic(s, "cube", "pose"), "rt/ipsd/cube/pose");
  EXPECT_TRUE(ros2::is_namespace("lab2/ipsd_3"));
  for (const char* bad : {"", "/ipsd", "ipsd/", "a//b", "2lab", "lab-2", "robot 1"})
    EXPECT_FALSE(ros2::is_namespace(bad)) << bad;
  EXPECT_EQ(ros2::to_stamp(-1).sec, -1);  // floor: nanosec stays in 0..1e9
  EXPECT_EQ(ros2::to_stamp(-1).nanosec, 999'999'999u);
  const auto q = ros2::yaw_quaternion(M_PI);
  EXPECT_NEAR(q.z, 1.0, 1e-12);
  EXPECT_NEAR(q.w, 0.0, 1e-12);
}

}  // namespace
}  // namespace ips
