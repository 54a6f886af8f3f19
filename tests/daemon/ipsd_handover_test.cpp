// Cameras and ranges in one daemon (docs/ranging.md, "Fusion with the cameras"): a robot drives
// from under a camera out of its view for ~20 s and back, carrying a UWB-like tag (4 anchors,
// 5 cm ranges) fired by the simulator's ranging source in step with the synthetic camera. Every
// record of the robot is checked against the scene's exact pose at its capture time: camera
// accuracy where the camera sees it, the ranges' where it does not, and no jump at the
// hand-overs beyond what the robot itself moved.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "ips/sim/scene.h"
#include "plane_model.h"
#include "process_util.h"
#include "published_scene.h"
#include "release_only.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

// Marker 5 drives from under the white camera (2.4, 2.3) to x = 8 m and back at 0.3 m/s (the
// camera loses it beyond x ~ 5 m: ~20 s out of view); the anchors span the whole run.
constexpr const char* kRobotAndAnchors = R"(markers:
  - id: 5
    length: 0.20
    height: 0.15
    trajectory: {type: waypoints, points: [[2.4, 2.3], [8.0, 2.3]], speed: 0.3}
anchors:
  - {id: 1, position: [0.0, 0.0, 2.5], sigma: 0.05}
  - {id: 2, position: [14.0, 0.0, 1.5], sigma: 0.05}
  - {id: 3, position: [14.0, 5.0, 2.5], sigma: 0.05}
  - {id: 4, position: [0.0, 5.0, 1.5], sigma: 0.05}
tags:
  - {id: 7, marker: 5}
)";

struct Record {
  std::int64_t t_real;
  Eigen::Vector3d p;
  bool camera;  // a camera placed it (else: the ranges alone)
};

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[static_cast<std::size_t>(0.95 * static_cast<double>(v.size() - 1))];
}

TEST(IpsdHandover, ARobotLeavingTheCamerasIsCarriedByItsRangesAndHandedBack) {
  IPS_RELEASE_ONLY("TrackFusionSources (tests/fusion) and IpsdRangingSim");
  const fs::path dir = fs::temp_directory_path() / ("ipsd_handover_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "scene.yaml") << test::published_scene_with(kRobotAndAnchors);
  test::write_plane_model(dir / "scene.yaml", dir / "model.json");
  const sim::Scene scene = sim::Scene::load(dir / "scene.yaml");
  test::UdpReceiver rx;
  const std::uint16_t port = test::free_udp_port();
  std::ostringstream config;
  config << "cameras:\n  - {name: white, source: synthetic, scene: scene.yaml, fps: 10}\n"
         << "markers:\n  ids:\n    5: {height: 0.15}\nmodel_file: model.json\n"
         << "outputs:\n  - {type: unicast, address: 127.0.0.1, port: " << rx.port << "}\n"
         << "status: {interval: 1, socket: " << (dir / "status.sock").string() << "}\n"
         << "ranging:\n  port: " << port << "\n  address: 127.0.0.1\n  height: 0.15\n  sigma: 0.05\n"
         << "  anchors:\n    - {id: 1, x: 0.0, y: 0.0, z: 2.5}\n    - {id: 2, x: 14.0, y: 0.0, z: 1.5}\n"
         << "    - {id: 3, x: 14.0, y: 5.0, z: 2.5}\n    - {id: 4, x: 0.0, y: 5.0, z: 1.5}\n"
         << "  tags:\n    - {id: 7, marker: 5}\n";
  std::ofstream(dir / "ipsd.yaml") << config.str();
  const fs::path log = dir / "ipsd.log";
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", (dir / "ipsd.yaml").string()}, log);
  const test::ChildGuard guard(pid);
  const std::int64_t start_limit = monotonic_ns() + static_cast<std::int64_t>(60e9);
  for (bool seen = false; !seen && monotonic_ns() < start_limit;)
    if (const auto bytes = rx.receive(100))
      for (const auto& m : decode_datagram(*bytes).markers) seen = seen || m.id == 5;
  ASSERT_LT(monotonic_ns(), start_limit) << test::read_file(log);
  const std::int64_t epoch =
      nlohmann::json::parse(test::read_unix_socket((dir / "status.sock").string()))["synthetic_epoch_mono_ns"];

  // One whole out-and-back (37 s) plus the start: the tag fires at 10 Hz in the camera's time.
  const fs::path sender_log = dir / "sender.log";
  const pid_t sender = test::spawn({test::bin("ips"), "sim", "ranges", "--scene", (dir / "scene.yaml").string(),
                                    "--send", "127.0.0.1:" + std::to_string(port), "--scene-epoch",
                                    std::to_string(epoch), "--seconds", "40", "--rate", "10", "--seed", "3"},
                                   sender_log);
  std::vector<Record> records;
  std::optional<int> sender_rc;
  for (std::int64_t until = 0; until == 0 || monotonic_ns() < until;) {
    if (!sender_rc) {
      sender_rc = test::wait_exit(sender, std::chrono::milliseconds(0));
      if (sender_rc) until = monotonic_ns() + 300'000'000;
    }
    if (const auto bytes = rx.receive(50)) {
      const Datagram d = decode_datagram(*bytes);
      for (const auto& m : d.markers)
        if (m.id == 5)
          records.push_back({d.capture_realtime_ns + 1000LL * m.dt_us, {m.x, m.y, m.z}, m.camera_mask != 0});
    }
  }
  ASSERT_EQ(sender_rc.value_or(-1), 0) << test::read_file(sender_log);
  const auto status = nlohmann::json::parse(test::read_unix_socket((dir / "status.sock").string()));

  // The scene's pose at each record's capture time (its realtime moved to the camera's clock).
  const std::int64_t real_minus_mono = realtime_minus_monotonic_ns();
  const auto truth = [&](std::int64_t t_real) {
    const sim::MarkerPose pose = scene.marker_pose(5, 1e-9 * static_cast<double>(t_real - real_minus_mono - epoch));
    return Eigen::Vector3d(pose.x, pose.y, 0.15);
  };
  std::vector<double> inside, outside, handover;
  double longest_out = 0, out_since = -1;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const Record& r = records[i];
    const double e = (r.p - truth(r.t_real)).head<2>().norm();
    (r.camera ? inside : outside).push_back(e);
    const double t = 1e-9 * static_cast<double>(r.t_real);
    if (!r.camera && out_since < 0) out_since = t;
    if (r.camera) out_since = -1;
    if (out_since >= 0) longest_out = std::max(longest_out, t - out_since);
    if (i == 0) continue;
    EXPECT_GE(r.t_real, records[i - 1].t_real) << "record " << i << " went back in time";
    if (r.camera != records[i - 1].camera) {
      // The step between the two records, beyond the robot's own motion between them.
      const Eigen::Vector3d moved = truth(r.t_real) - truth(records[i - 1].t_real);
      handover.push_back((r.p - records[i - 1].p - moved).head<2>().norm());
    }
  }
  std::printf(
      "[ handover ] %zu records: %zu by the camera, 2-D p95 %.1f mm; %zu by the ranges alone (longest "
      "stretch %.1f s), p95 %.1f mm; %zu hand-overs, largest step beyond the motion %.1f mm; ranging %s\n",
      records.size(), inside.size(), 1e3 * p95(inside), outside.size(), longest_out, 1e3 * p95(outside),
      handover.size(), handover.empty() ? 0.0 : 1e3 * *std::max_element(handover.begin(), handover.end()),
      status["ranging"].dump().c_str());
  // 189 camera records on a quiet machine; beside 4 busy loops the synthetic camera renders
  // late: 109 (18 before the hold followed the cameras' lag and their frames' age counted
  // from their own newest).
  ASSERT_GE(inside.size(), 10u) << test::read_file(log);
  EXPECT_GT(longest_out, 15.0) << "the robot must leave the camera's view for a while";
  EXPECT_LT(p95(inside), 0.02) << "camera accuracy where the camera sees it";
  // Measured 2026-11-27: camera 0.2 mm; ranges alone 77.3 mm over a 21.1 s stretch; steps at
  // the hand-overs 51.4 mm at most (docs/ranging.md).
  EXPECT_LT(p95(outside), 0.10);
  ASSERT_GE(handover.size(), 2u) << "out of view and back";
  EXPECT_GT(status["fusion_held_for_cameras"].get<int>(), 100)
      << "the fixes under the camera were merged into its records";
  for (double step : handover) EXPECT_LT(step, 3 * 0.05) << "a hand-over jumped beyond 3 sigma of a range";
  // The ranges taken under the camera are the daemon's survey of its anchors, in its status
  // (185 samples per anchor on a quiet machine; 21 beside 4 busy loops, where the starved
  // camera's states are mostly more than 0.3 s from a firing).
  const auto& anchors = status["ranging"]["anchors"];
  ASSERT_EQ(anchors.size(), 4u) << status["ranging"].dump();
  for (const auto& a : anchors) EXPECT_GT(a["samples"].get<int>(), 0) << a.dump();
  const fs::path said = dir / "status.txt";
  ASSERT_EQ(test::run({test::bin("ips"), "status", "--socket", (dir / "status.sock").string()}, said), 0);
  EXPECT_NE(test::read_file(said).find("anchor 1: "), std::string::npos) << test::read_file(said);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips
