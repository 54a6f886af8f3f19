// The real ipsd on three unsynchronised synthetic cameras of the published lab with the robots
// of config/scenes/bodies_lab.yaml (a marker cube, a two-marker robot) and one plain marker:
// the stream is version 2, the bodies' published poses match the simulator's body truth at
// each record's capture time (and their velocity and yaw rate the truth's derivatives), their
// markers are not also published as plain markers, and the plain marker still is.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bodies_lab_scene.h"
#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "ips/sim/scene.h"
#include "plane_model.h"
#include "process_util.h"
#include "release_only.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

double p95(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(v.size()))) - 1];
}

TEST(IpsdBodies, PublishedBodyPosesMatchTheSimulatorsTruth) {
  // ~8 s of a daemon with three rendering cameras: CPU-bound, and its accuracy depends on
  // frames not being dropped.
  IPS_RELEASE_ONLY("BodyTrack.* (the asynchronous body fusion) and WireV2.* (the record)");
  const fs::path dir = fs::temp_directory_path() / ("ipsd_bodies_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "scene.yaml") << test::bodies_lab_scene();
  test::write_plane_model(dir / "scene.yaml", dir / "model.json");
  test::UdpReceiver rx;
  std::string cfg = "cameras:\n";
  const char* names[] = {"red", "white", "black"};
  const double phases[] = {0.0, 0.011, 0.023};
  for (int c = 0; c < 3; ++c)
    cfg += std::string("  - {name: ") + names[c] +
           ", source: synthetic, scene: scene.yaml, fps: 10, phase: " + std::to_string(phases[c]) + "}\n";
  cfg += test::bodies_lab_daemon_sections();
  cfg += "model_file: model.json\noutputs:\n  - {type: unicast, address: 127.0.0.1, port: " + std::to_string(rx.port) +
         ", format: binary}\n";
  std::ofstream(dir / "ipsd.yaml") << cfg;
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", (dir / "ipsd.yaml").string()}, dir / "ipsd.log");
  const test::ChildGuard guard(pid);

  struct Rec {
    BodyRecord b;
    std::int64_t t;
  };
  std::vector<Rec> bodies;
  std::map<std::uint32_t, int> markers;
  std::size_t datagrams = 0, v2 = 0;
  // 6 s after the first datagram, and on (up to 90 s) until each body has 25 records with a
  // velocity: a busy machine renders fewer frames (29 records in 6 s beside 4 busy loops and
  // another test), and the test asserts accuracy, not throughput.
  const std::int64_t limit = monotonic_ns() + 30'000'000'000LL, hard_limit = monotonic_ns() + 90'000'000'000LL;
  std::int64_t end = 0;
  std::map<std::string, int> with_velocity;
  const auto enough = [&] { return with_velocity["turtle"] >= 25 && with_velocity["long"] >= 25; };
  while (monotonic_ns() < (end ? end : limit) || (end && !enough() && monotonic_ns() < hard_limit)) {
    auto bytes = rx.receive(100);
    if (!bytes) continue;
    if (!end) end = monotonic_ns() + 6'000'000'000LL;
    const Datagram d = decode_datagram(*bytes);
    ++datagrams;
    v2 += d.version == 2;
    for (const auto& m : d.markers) ++markers[m.id];
    for (const auto& b : d.bodies) {
      bodies.push_back({b, d.capture_monotonic_ns + 1000LL * b.dt_us});
      with_velocity[b.name] += b.has_velocity && b.has_yaw_rate;
    }
  }
  const std::string log = test::read_file(dir / "ipsd.log");
  ASSERT_GT(datagrams, 0u) << log;
  EXPECT_EQ(v2, datagrams);
  EXPECT_GT(markers[3], 10) << "the plain marker is still published";
  for (const std::uint32_t id : {5u, 7u, 8u})
    EXPECT_EQ(markers.count(id), 0u) << "body marker " << id << " published as a marker";
  EXPECT_EQ(log.find("do not publish"), std::string::npos) << log;

  // The synthetic cameras' scene time 0 is the daemon's start, logged.
  const auto at = log.find("scene time 0 = CLOCK_MONOTONIC ");
  ASSERT_NE(at, std::string::npos) << log;
  const std::int64_t epoch = std::stoll(log.substr(at + 31));
  const auto scene = sim::Scene::load(dir / "scene.yaml");
  std::map<std::string, std::vector<double>> pos_err, yaw_err, vel_err, rate_err;
  std::map<std::string, std::int64_t> last;
  std::size_t backwards = 0;
  for (const auto& r : bodies) {
    const std::size_t index = r.b.name == "turtle" ? 0 : 1;
    ASSERT_EQ(scene.bodies[index].def.name, r.b.name);
    const BodyPose truth = scene.body_pose_at(index, 1e-9 * static_cast<double>(r.t - epoch));
    pos_err[r.b.name].push_back(std::hypot(r.b.x - truth.position.x(), r.b.y - truth.position.y()));
    if (r.b.has_yaw)
      yaw_err[r.b.name].push_back(std::abs(std::remainder(r.b.yaw - truth.yaw, 2 * std::numbers::pi)) * 180 /
                                  std::numbers::pi);
    // Velocity and yaw rate: the truth's central differences at the record's time. The daemon's
    // are means over fusion.velocity_span (0.2 s) ending there: on this 1.95 m circle at 0.5
    // m/s they lag the truth's direction by 0.1 s of turning, 1.3 cm/s.
    if (r.b.has_velocity) {
      const double t = 1e-9 * static_cast<double>(r.t - epoch), h = 1e-3;
      const BodyPose a = scene.body_pose_at(index, t - h), b = scene.body_pose_at(index, t + h);
      const Eigen::Vector3d v = (b.position - a.position) / (2 * h);
      vel_err[r.b.name].push_back(std::hypot(r.b.vx - v.x(), r.b.vy - v.y()));
      if (r.b.has_yaw_rate)
        rate_err[r.b.name].push_back(
            std::abs(r.b.yaw_rate - std::remainder(b.yaw - a.yaw, 2 * std::numbers::pi) / (2 * h)));
    }
    auto [it, fresh] = last.try_emplace(r.b.name, r.t);
    if (!fresh && r.t < it->second) ++backwards;
    it->second = std::max(it->second, r.t);
  }
  EXPECT_EQ(backwards, 0u) << "body records that went back in capture time";
  for (const char* name : {"turtle", "long"}) {
    std::printf("[ ipsd    ] body %s: %zu records, position error p95 %.2f mm, yaw error p95 %.2f deg (%zu with yaw)\n",
                name, pos_err[name].size(), 1e3 * p95(pos_err[name]), p95(yaw_err[name]), yaw_err[name].size());
    ASSERT_GT(pos_err[name].size(), 20u) << name;
    EXPECT_LE(p95(pos_err[name]), 0.015) << name;
    ASSERT_GT(yaw_err[name].size(), 20u) << name;
    EXPECT_LE(p95(yaw_err[name]), 2.0) << name;
    std::printf("[ ipsd    ] body %s: velocity error p95 %.1f mm/s (%zu), yaw rate error p95 %.2f deg/s (%zu)\n", name,
                1e3 * p95(vel_err[name]), vel_err[name].size(), p95(rate_err[name]) * 180 / std::numbers::pi,
                rate_err[name].size());
    ASSERT_GT(vel_err[name].size(), 20u) << name;
    EXPECT_LE(p95(vel_err[name]), 0.05) << name;  // 10 % of the speed
    ASSERT_GT(rate_err[name].size(), 20u) << name;
    // rad/s (4.6 deg/s; the truth is 0.256 rad/s): measured 1.1-2.0 deg/s, yaw noise over the
    // span; a loaded machine leaves fewer poses in it.
    EXPECT_LE(p95(rate_err[name]), 0.08) << name;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips
