// The MAVLink output end to end through a socket: frames sent by MavlinkSink decoded by an
// independent implementation (node-mavlink) field by field; heartbeat, rate limit and
// reset_counter read from the frames' bytes.
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>

#include <gtest/gtest.h>

#include "ips/output/mavlink_frame.h"
#include "ips/output/mavlink_pose.h"
#include "ips/output/output_sink.h"
#include "ips/output/wire.h"
#include "loopback_udp.h"
#include "mavlink_decoder.h"

namespace ips {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

std::vector<std::vector<std::uint8_t>> drain(support::UdpReceiver& rx) {
  std::vector<std::vector<std::uint8_t>> out;
  while (auto d = rx.receive(200)) out.push_back(std::move(*d));
  return out;
}

OutputConfig mavlink_to(std::uint16_t port) {
  OutputConfig o;
  o.kind = OutputConfig::Kind::kMavlink;
  o.address = "127.0.0.1";
  o.port = port;
  o.mavlink.vehicles = {{3, 7, "", 0, 0.0}, {5, 9, "", 0, 90.0}};
  o.mavlink.odometry = true;
  o.mavlink.rate_limit_hz = 50;
  o.mavlink.yaw_offset_deg = 30;
  o.mavlink.track_gap_s = 0.5;
  o.mavlink.yaw_stddev_deg = 4;
  return o;
}

MarkerRecord marker(std::uint32_t id, double x, double y, double z, double yaw) {
  MarkerRecord m;
  m.id = id;
  m.x = x, m.y = y, m.z = z, m.yaw = yaw;
  m.vx = 0.3, m.vy = -0.2, m.vz = 0.05;
  m.covariance = {1e-4, 2e-5, 0, 3e-4, -1e-5, 5e-4};
  return m;
}

struct FrameHead {
  std::uint32_t msgid;
  std::uint8_t seq, sys, comp, len;
  std::vector<std::uint8_t> payload;  // zero-filled back to its full length by the caller if needed
};

FrameHead head(const std::vector<std::uint8_t>& f) {
  FrameHead h{};
  h.len = f.at(1);
  h.seq = f.at(4);
  h.sys = f.at(5);
  h.comp = f.at(6);
  h.msgid = f.at(7) | (f.at(8) << 8) | (f.at(9) << 16);
  h.payload.assign(f.begin() + 10, f.begin() + 10 + h.len);
  return h;
}

TEST(MavlinkSink, NodeMavlinkDecodesEveryFieldAsSent) {
  const std::string why = test::node_missing_reason();
  if (!why.empty()) GTEST_SKIP() << why;
  ASSERT_TRUE(test::decoder_installed()) << "node-mavlink is not installed: run tools/setup.sh (npm ci in "
                                         << test::mavlink_decoder_dir() << ")";
  support::UdpReceiver rx;
  const OutputConfig config = mavlink_to(rx.port);
  auto sink = make_output_sink(config, 0);

  Datagram d;
  d.has_velocity = true;
  d.capture_realtime_ns = 1'700'000'000'123'456'789LL;
  d.capture_monotonic_ns = 5'000'000'000LL;
  d.markers = {marker(3, 1.25, 2.5, 0.75, 0.4), marker(4, 9, 9, 9, 0), marker(5, -0.5, 1.0, 1.5, -2.0)};
  d.has_sources = true;
  d.markers[2].sources = IPS_WIRE_SOURCE_RANGES;  // vehicle 9: ranges alone, its heading held
  d.markers[2].camera_mask = 0;
  d.markers[2].has_yaw = false;
  sink->publish(d);
  const auto frames = drain(rx);
  // Per vehicle: HEARTBEAT, VISION_POSITION_ESTIMATE, ODOMETRY (marker 4 is no vehicle).
  ASSERT_EQ(frames.size(), 6u);

  // A negative control at the end: one payload bit flipped must fail the decoder's checksum.
  auto with_control = frames;
  with_control.push_back(frames[1]);
  with_control.back()[12] ^= 0x01;
  std::string error;
  const auto doc = test::decode_mavlink(
      with_control, std::filesystem::temp_directory_path() / ("mavlink_sink_" + std::to_string(::getpid()) + ".bin"),
      error);
  ASSERT_TRUE(doc) << error;
  EXPECT_EQ((*doc)["crc_errors"], 1);  // the control, and only it
  const auto& packets = (*doc)["packets"];
  ASSERT_EQ(packets.size(), frames.size()) << doc->dump();

  std::map<int, int> next_seq;
  for (std::size_t i = 0; i < packets.size(); ++i) {
    const auto& p = packets[i];
    const FrameHead h = head(frames[i]);
    SCOPED_TRACE("packet " + std::to_string(i) + ": " + p.dump());
    EXPECT_EQ(p["magic"], 0xFD);
    EXPECT_EQ(p["msgid"], h.msgid);
    EXPECT_EQ(p["compid"], 197);
    const int sys = p["sysid"];
    ASSERT_TRUE(sys == 7 || sys == 9);
    // Sequence: per (system, component), +1 per frame.
    if (next_seq.count(sys)) {
      EXPECT_EQ(p["seq"], next_seq[sys]);
    }
    next_seq[sys] = (p["seq"].get<int>() + 1) % 256;

    const MarkerRecord& m = d.markers[sys == 7 ? 0 : 2];
    const MavlinkPose want = lab_to_ned(m, 30 * kDeg, (sys == 7 ? 0.0 : 90.0) * kDeg);
    const double att_var = std::pow(4 * kDeg, 2);
    const double yaw_var = m.has_yaw ? att_var : kHeldYawVariance;
    const auto& f = p["fields"];
    auto fl = [&](const nlohmann::json& v) { return test::json_float(v); };
    auto expect_pose_covariance = [&](const nlohmann::json& c) {
      ASSERT_EQ(c.size(), 21u);
      const double expected[21] = {want.cov[0][0],
                                   want.cov[0][1],
                                   want.cov[0][2],
                                   0,
                                   0,
                                   0,
                                   want.cov[1][1],
                                   want.cov[1][2],
                                   0,
                                   0,
                                   0,
                                   want.cov[2][2],
                                   0,
                                   0,
                                   0,
                                   att_var,
                                   0,
                                   0,
                                   att_var,
                                   0,
                                   yaw_var};
      for (int k = 0; k < 21; ++k)
        EXPECT_FLOAT_EQ(fl(c[k]), static_cast<float>(expected[k])) << "covariance[" << k << "]";
    };
    const std::uint64_t usec = static_cast<std::uint64_t>(d.capture_realtime_ns / 1000);
    switch (h.msgid) {
      case mavlink::kMsgHeartbeat:
        EXPECT_EQ(p["name"], "HEARTBEAT");
        EXPECT_EQ(f["type"], 18);      // MAV_TYPE_ONBOARD_CONTROLLER
        EXPECT_EQ(f["autopilot"], 8);  // MAV_AUTOPILOT_INVALID
        EXPECT_EQ(f["base_mode"], 0);
        EXPECT_EQ(f["custom_mode"], 0);
        EXPECT_EQ(f["system_status"], 4);  // MAV_STATE_ACTIVE
        EXPECT_EQ(f["mavlink_version"], 3);
        break;
      case mavlink::kMsgVisionPositionEstimate:
        EXPECT_EQ(p["name"], "VISION_POSITION_ESTIMATE");
        EXPECT_EQ(f["usec"], std::to_string(usec));
        EXPECT_FLOAT_EQ(fl(f["x"]), static_cast<float>(want.n));
        EXPECT_FLOAT_EQ(fl(f["y"]), static_cast<float>(want.e));
        EXPECT_FLOAT_EQ(fl(f["z"]), static_cast<float>(want.d));
        EXPECT_EQ(fl(f["roll"]), 0.0);
        EXPECT_EQ(fl(f["pitch"]), 0.0);
        EXPECT_FLOAT_EQ(fl(f["yaw"]), static_cast<float>(want.heading));
        expect_pose_covariance(f["covariance"]);
        EXPECT_EQ(f["reset_counter"], 0);
        break;
      case mavlink::kMsgOdometry: {
        EXPECT_EQ(p["name"], "ODOMETRY");
        EXPECT_EQ(f["time_usec"], std::to_string(usec));
        EXPECT_EQ(f["frame_id"], 20);        // MAV_FRAME_LOCAL_FRD
        EXPECT_EQ(f["child_frame_id"], 12);  // MAV_FRAME_BODY_FRD
        EXPECT_FLOAT_EQ(fl(f["x"]), static_cast<float>(want.n));
        EXPECT_FLOAT_EQ(fl(f["y"]), static_cast<float>(want.e));
        EXPECT_FLOAT_EQ(fl(f["z"]), static_cast<float>(want.d));
        EXPECT_FLOAT_EQ(fl(f["q"][0]), static_cast<float>(std::cos(want.heading / 2)));
        EXPECT_EQ(fl(f["q"][1]), 0.0);
        EXPECT_EQ(fl(f["q"][2]), 0.0);
        EXPECT_FLOAT_EQ(fl(f["q"][3]), static_cast<float>(std::sin(want.heading / 2)));
        // Body FRD velocity: the local one rotated by the heading.
        const double ch = std::cos(want.heading), sh = std::sin(want.heading);
        EXPECT_FLOAT_EQ(fl(f["vx"]), static_cast<float>(ch * want.vn + sh * want.ve));
        EXPECT_FLOAT_EQ(fl(f["vy"]), static_cast<float>(-sh * want.vn + ch * want.ve));
        EXPECT_FLOAT_EQ(fl(f["vz"]), static_cast<float>(want.vd));
        EXPECT_TRUE(std::isnan(fl(f["rollspeed"])));
        EXPECT_TRUE(std::isnan(fl(f["pitchspeed"])));
        EXPECT_TRUE(std::isnan(fl(f["yawspeed"])));
        expect_pose_covariance(f["pose_covariance"]);
        EXPECT_TRUE(std::isnan(fl(f["velocity_covariance"][0])));  // unknown
        for (int k = 1; k < 21; ++k) EXPECT_EQ(fl(f["velocity_covariance"][k]), 0.0);
        EXPECT_EQ(f["reset_counter"], 0);
        EXPECT_EQ(f["estimator_type"], 6);  // MAV_ESTIMATOR_TYPE_MOCAP
        EXPECT_EQ(f["quality"], 0);
        break;
      }
      default: ADD_FAILURE() << "unexpected message " << h.msgid;
    }
  }
}

// Counts pose frames and reads reset_counter (VISION_POSITION_ESTIMATE payload byte 116,
// zero-filled when truncated) from the bytes.
struct Poses {
  int heartbeats = 0;
  std::vector<int> reset_counters;
};
Poses poses(const std::vector<std::vector<std::uint8_t>>& frames) {
  Poses p;
  for (const auto& f : frames) {
    const FrameHead h = head(f);
    if (h.msgid == mavlink::kMsgHeartbeat) ++p.heartbeats;
    if (h.msgid == mavlink::kMsgVisionPositionEstimate) p.reset_counters.push_back(h.len > 116 ? h.payload[116] : 0);
  }
  return p;
}

TEST(MavlinkSink, RateLimitResetCounterAndOneHeartbeatPerSecond) {
  support::UdpReceiver rx;
  OutputConfig config = mavlink_to(rx.port);
  config.mavlink.vehicles.resize(1);
  config.mavlink.odometry = false;
  config.mavlink.rate_limit_hz = 30;
  auto sink = make_output_sink(config, 0);

  // 100 Hz for one second of stream time (published as fast as possible: well under 1 s of
  // wall time, so exactly one heartbeat): the rate limit passes 30 per second (+1 at the start).
  auto publish_at = [&](std::int64_t t_ns) {
    Datagram d;
    d.capture_monotonic_ns = t_ns;
    d.capture_realtime_ns = t_ns + 1'000'000'000'000LL;
    d.markers = {marker(3, 1, 1, 1, 0)};
    sink->publish(d);
  };
  const std::int64_t t0 = 10'000'000'000LL;
  for (int k = 0; k < 100; ++k) publish_at(t0 + k * 10'000'000LL);
  Poses p = poses(drain(rx));
  EXPECT_EQ(p.heartbeats, 1);
  EXPECT_GE(p.reset_counters.size(), 30u);
  EXPECT_LE(p.reset_counters.size(), 31u);
  for (int r : p.reset_counters) EXPECT_EQ(r, 0);

  // Unseen 0.4 s (< track_gap 0.5 s): the same track. Then unseen 0.6 s: a new track.
  publish_at(t0 + 1'390'000'000LL);
  publish_at(t0 + 1'990'000'000LL);
  publish_at(t0 + 2'000'000'000LL);  // rate-limited or not, a restart is never counted twice
  publish_at(t0 + 2'100'000'000LL);
  p = poses(drain(rx));
  ASSERT_GE(p.reset_counters.size(), 3u);
  EXPECT_EQ(p.reset_counters.front(), 0);
  for (std::size_t i = 1; i < p.reset_counters.size(); ++i) EXPECT_EQ(p.reset_counters[i], 1);

  const OutputStats s = sink->stats();
  EXPECT_EQ(s.send_errors, 0u);
  EXPECT_GT(s.bytes, 0u);
  EXPECT_EQ(s.description, "mavlink 127.0.0.1:" + std::to_string(rx.port) + " (1 vehicle(s))");
}

// One vehicle (marker 3) without ODOMETRY, and a version-2 update at a fixed instant: the
// body tests' sink and datagram.
std::unique_ptr<OutputSink> marker_3_sink(std::uint16_t port) {
  OutputConfig config = mavlink_to(port);
  config.mavlink.vehicles.resize(1);  // marker 3
  config.mavlink.odometry = false;
  return make_output_sink(config, 0);
}

Datagram body_update() {
  Datagram d;
  d.version = 2;
  d.capture_monotonic_ns = 5'000'000'000LL;
  d.capture_realtime_ns = 1'700'000'000'000'000'000LL;
  return d;
}

TEST(MavlinkSink, AVehicleWhoseMarkerIsOnABodyGetsTheBodysPose) {
  support::UdpReceiver rx;
  auto sink = marker_3_sink(rx.port);
  Datagram d = body_update();
  BodyRecord other, mine;
  other.name = "other";  // lists marker 3 too, but without a yaw: skipped
  other.ids = {3};
  other.id_count = 1;
  other.has_yaw = false;
  mine.name = "robot";
  mine.x = 1.5, mine.y = 2.0, mine.z = 0.0, mine.yaw = 0.3;
  mine.has_yaw = true;
  mine.ids = {2, 3};
  mine.id_count = 2;
  d.bodies = {other, mine};
  sink->publish(d);
  // Without a known yaw the body gives the vehicle nothing.
  d.capture_monotonic_ns += 100'000'000;
  d.bodies[1].has_yaw = false;
  sink->publish(d);
  const MavlinkPose want = lab_to_ned(marker(3, 1.5, 2.0, 0.0, 0.3), 30 * kDeg, 0.0);
  int poses_seen = 0;
  for (const auto& f : drain(rx)) {
    const FrameHead h = head(f);
    if (h.msgid != mavlink::kMsgVisionPositionEstimate) continue;
    ++poses_seen;
    float x = 0, y = 0;
    std::memcpy(&x, h.payload.data() + 8, 4);  // usec u64, then x, y, z, roll, pitch, yaw (f32)
    std::memcpy(&y, h.payload.data() + 12, 4);
    EXPECT_FLOAT_EQ(x, static_cast<float>(want.n));
    EXPECT_FLOAT_EQ(y, static_cast<float>(want.e));
  }
  EXPECT_EQ(poses_seen, 1);
}

// Out of the cameras' view a body placed by its tag's ranges alone names no marker: the vehicle
// whose marker was last seen on that body still gets it, with the held yaw and its variance.
TEST(MavlinkSink, ABodyPlacedByRangesAloneReachesTheVehicleWithItsYawHeld) {
  support::UdpReceiver rx;
  auto sink = marker_3_sink(rx.port);
  Datagram d = body_update();
  d.has_sources = true;
  BodyRecord seen;
  seen.name = "robot";
  seen.x = 1.5, seen.y = 2.0, seen.yaw = 0.3;
  seen.has_yaw = true;
  seen.ids = {2, 3};
  seen.id_count = 2;
  seen.camera_mask = 1;
  seen.covariance = {4e-6, 0, 0, 4e-6, 0, 4e-6};
  d.bodies = {seen};
  sink->publish(d);
  BodyRecord ranged = seen;
  ranged.x = 2.5;
  ranged.ids.clear();
  ranged.id_count = 0;
  ranged.camera_mask = 0;
  ranged.has_yaw = false;  // 0.3 held
  ranged.sources = IPS_WIRE_SOURCE_RANGES;
  ranged.covariance = {0.0025, 0, 0, 0.0025, 0, 0.0025};
  d.capture_monotonic_ns += 100'000'000;
  d.bodies = {ranged};
  sink->publish(d);
  BodyRecord stranger = ranged;  // another body placed by ranges: not this vehicle's
  stranger.name = "stranger";
  d.capture_monotonic_ns += 100'000'000;
  d.bodies = {stranger};
  sink->publish(d);
  std::vector<std::pair<float, float>> xs;  // x, yaw variance
  for (const auto& f : drain(rx)) {
    const FrameHead h = head(f);
    if (h.msgid != mavlink::kMsgVisionPositionEstimate) continue;
    float x = 0, yaw_variance = 0;
    std::memcpy(&x, h.payload.data() + 8, 4);
    std::memcpy(&yaw_variance, h.payload.data() + 32 + 4 * 20, 4);  // covariance[20]: yaw, yaw
    xs.emplace_back(x, yaw_variance);
  }
  ASSERT_EQ(xs.size(), 2u);
  EXPECT_FLOAT_EQ(xs[0].first, static_cast<float>(lab_to_ned(marker(3, 1.5, 2.0, 0.0, 0.3), 30 * kDeg, 0.0).n));
  EXPECT_FLOAT_EQ(xs[1].first, static_cast<float>(lab_to_ned(marker(3, 2.5, 2.0, 0.0, 0.3), 30 * kDeg, 0.0).n));
  EXPECT_LT(xs[0].second, 1.0f);
  EXPECT_FLOAT_EQ(xs[1].second, static_cast<float>(kHeldYawVariance));
}

TEST(MavlinkSink, ABodysOdometryCarriesItsVelocityAndYawRate) {
  const std::string why = test::node_missing_reason();
  if (!why.empty()) GTEST_SKIP() << why;
  ASSERT_TRUE(test::decoder_installed()) << "node-mavlink is not installed: run tools/setup.sh";
  support::UdpReceiver rx;
  OutputConfig config = mavlink_to(rx.port);
  config.mavlink.vehicles.resize(1);  // marker 3, yaw offset 30 degrees
  auto sink = make_output_sink(config, 0);
  Datagram d;
  d.version = 2;  // no marker velocity (no Kalman): the body's own velocity counts
  d.capture_monotonic_ns = 5'000'000'000LL;
  d.capture_realtime_ns = 1'700'000'000'000'000'000LL;
  BodyRecord b;
  b.name = "robot";
  b.x = 1.5, b.y = 2.0, b.yaw = 0.3;
  b.has_yaw = true;
  b.ids = {3};
  b.id_count = 1;
  b.has_velocity = true;
  b.vx = 0.4, b.vy = -0.1, b.vz = 0.0;
  b.has_yaw_rate = true;
  b.yaw_rate = 0.25;  // counter-clockwise in the lab
  d.bodies = {b};
  sink->publish(d);
  d.capture_monotonic_ns += 100'000'000;
  d.capture_realtime_ns += 100'000'000;
  d.bodies[0].has_velocity = d.bodies[0].has_yaw_rate = false;  // not measured: NaN, never 0
  sink->publish(d);
  const auto frames = drain(rx);
  std::string error;
  const auto doc = test::decode_mavlink(
      frames, std::filesystem::temp_directory_path() / ("mavlink_body_" + std::to_string(::getpid()) + ".bin"), error);
  ASSERT_TRUE(doc) << error;
  MarkerRecord m = marker(3, 1.5, 2.0, 0.0, 0.3);
  m.vx = 0.4, m.vy = -0.1, m.vz = 0.0;
  const MavlinkPose want = lab_to_ned(m, 30 * kDeg, 0.0);
  std::vector<nlohmann::json> odometry;
  for (const auto& p : (*doc)["packets"])
    if (p["name"] == "ODOMETRY") odometry.push_back(p["fields"]);
  ASSERT_EQ(odometry.size(), 2u) << doc->dump();
  auto fl = [](const nlohmann::json& v) { return test::json_float(v); };
  const double ch = std::cos(want.heading), sh = std::sin(want.heading);
  EXPECT_FLOAT_EQ(fl(odometry[0]["vx"]), static_cast<float>(ch * want.vn + sh * want.ve));
  EXPECT_FLOAT_EQ(fl(odometry[0]["vy"]), static_cast<float>(-sh * want.vn + ch * want.ve));
  // Hand-computed: a body driving along its own heading (lab yaw 0.3, velocity along
  // (cos 0.3, sin 0.3)) would read (|v|, 0); this one's velocity is 0.4124 m/s at -0.245 rad,
  // 0.545 rad clockwise of its heading: forward 0.3535, right 0.2140.
  EXPECT_NEAR(fl(odometry[0]["vx"]), 0.4123 * std::cos(0.5450), 2e-3);
  EXPECT_NEAR(fl(odometry[0]["vy"]), 0.4123 * std::sin(0.5450), 2e-3);
  EXPECT_FLOAT_EQ(fl(odometry[0]["yawspeed"]), -0.25f);  // clockwise positive about FRD's down
  EXPECT_TRUE(std::isnan(fl(odometry[0]["rollspeed"])));
  EXPECT_TRUE(std::isnan(fl(odometry[1]["vx"])));
  EXPECT_TRUE(std::isnan(fl(odometry[1]["yawspeed"])));
}

}  // namespace
}  // namespace ips
