// Cameras and ranges in one daemon (docs/ranging.md, "Fusion with the cameras"): a robot drives
// from under a camera out of its view for ~20 s and back, carrying a UWB-like tag (4 anchors,
// 5 cm ranges) fired by the simulator's ranging source in step with the synthetic camera. Every
// record of the robot is checked against the scene's exact pose at its capture time: camera
// accuracy where the camera sees it, the ranges' where it does not, and no jump at the
// hand-overs beyond what the robot itself moved.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"
#include "ips/sim/scene.h"
#include "plane_model.h"
#include "process_util.h"
#include "published_scene.h"
#include "release_only.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

// 4 anchors spanning 14 x 5 m, 5 cm ranges (the daemon's ranging.anchors in run_handover).
constexpr const char* kAnchors = R"(anchors:
  - {id: 1, position: [0.0, 0.0, 2.5], sigma: 0.05}
  - {id: 2, position: [14.0, 0.0, 1.5], sigma: 0.05}
  - {id: 3, position: [14.0, 5.0, 2.5], sigma: 0.05}
  - {id: 4, position: [0.0, 5.0, 1.5], sigma: 0.05}
)";

// Marker 5 drives from under the white camera (2.4, 2.3) to x = 8 m and back at 0.3 m/s (the
// camera loses it beyond x ~ 5 m: ~20 s out of view); the anchors span the whole run.
constexpr const char* kRobot = R"(markers:
  - id: 5
    length: 0.20
    height: 0.15
    trajectory: {type: waypoints, points: [[2.4, 2.3], [8.0, 2.3]], speed: 0.3}
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

// One run: ipsd on the white camera and the ranges of the scene's tags, 40 s of firings at
// 10 Hz; `pick` turns each datagram into the robot's records.
struct HandoverRun {
  fs::path dir;
  fs::path log;
  sim::Scene scene;
  std::int64_t epoch = 0;
  std::vector<Record> records;
  nlohmann::json status;
  std::string status_text;  // `ips status` at the end (ipsd stops when run_handover returns)
};

HandoverRun run_handover(const std::string& name, const std::string& scene_part, const std::string& daemon_part,
                         const std::string& tags,
                         const std::function<void(const Datagram&, std::vector<Record>&)>& pick) {
  HandoverRun run;
  run.dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::create_directories(run.dir);
  const fs::path& dir = run.dir;
  std::ofstream(dir / "scene.yaml") << test::published_scene_with(scene_part);
  test::write_plane_model(dir / "scene.yaml", dir / "model.json");
  run.scene = sim::Scene::load(dir / "scene.yaml");
  test::UdpReceiver rx;
  const std::uint16_t port = test::free_udp_port();
  std::ostringstream config;
  config << "cameras:\n  - {name: white, source: synthetic, scene: scene.yaml, fps: 10}\n"
         << daemon_part << "model_file: model.json\n"
         << "outputs:\n  - {type: unicast, address: 127.0.0.1, port: " << rx.port << "}\n"
         << "status: {interval: 1, socket: " << (dir / "status.sock").string() << "}\n"
         << "ranging:\n  port: " << port << "\n  address: 127.0.0.1\n  sigma: 0.05\n"
         << "  anchors:\n    - {id: 1, x: 0.0, y: 0.0, z: 2.5}\n    - {id: 2, x: 14.0, y: 0.0, z: 1.5}\n"
         << "    - {id: 3, x: 14.0, y: 5.0, z: 2.5}\n    - {id: 4, x: 0.0, y: 5.0, z: 1.5}\n"
         << tags;
  std::ofstream(dir / "ipsd.yaml") << config.str();
  run.log = dir / "ipsd.log";
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", (dir / "ipsd.yaml").string()}, run.log);
  const test::ChildGuard guard(pid);
  const std::int64_t start_limit = monotonic_ns() + static_cast<std::int64_t>(60e9);
  for (bool seen = false; !seen && monotonic_ns() < start_limit;)
    if (const auto bytes = rx.receive(100)) {
      std::vector<Record> first;
      pick(decode_datagram(*bytes), first);
      seen = !first.empty();
    }
  EXPECT_LT(monotonic_ns(), start_limit) << test::read_file(run.log);
  if (monotonic_ns() >= start_limit) return run;
  run.epoch = nlohmann::json::parse(test::read_unix_socket((dir / "status.sock").string()))["synthetic_epoch_mono_ns"];

  // One whole out-and-back (37 s) plus the start: the tag fires at 10 Hz in the camera's time.
  const fs::path sender_log = dir / "sender.log";
  const pid_t sender = test::spawn({test::bin("ips"), "sim", "ranges", "--scene", (dir / "scene.yaml").string(),
                                    "--send", "127.0.0.1:" + std::to_string(port), "--scene-epoch",
                                    std::to_string(run.epoch), "--seconds", "40", "--rate", "10", "--seed", "3"},
                                   sender_log);
  std::optional<int> sender_rc;
  for (std::int64_t until = 0; until == 0 || monotonic_ns() < until;) {
    if (!sender_rc) {
      sender_rc = test::wait_exit(sender, std::chrono::milliseconds(0));
      if (sender_rc) until = monotonic_ns() + 300'000'000;
    }
    if (const auto bytes = rx.receive(50)) pick(decode_datagram(*bytes), run.records);
  }
  EXPECT_EQ(sender_rc.value_or(-1), 0) << test::read_file(sender_log);
  run.status = nlohmann::json::parse(test::read_unix_socket((dir / "status.sock").string()));
  const fs::path said = dir / "status.txt";
  EXPECT_EQ(test::run({test::bin("ips"), "status", "--socket", (dir / "status.sock").string()}, said), 0);
  run.status_text = test::read_file(said);
  return run;
}

// Per record: its 2-D error against `truth`, inside (a camera placed it) or outside; the
// longest stretch of ranges alone; the steps at the hand-overs beyond the robot's own motion.
struct HandoverFigures {
  std::vector<double> inside, outside, handover;
  double longest_out = 0;
};

HandoverFigures figures(const std::vector<Record>& records, const std::function<Eigen::Vector3d(std::int64_t)>& truth) {
  HandoverFigures f;
  double out_since = -1;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const Record& r = records[i];
    const double e = (r.p - truth(r.t_real)).head<2>().norm();
    (r.camera ? f.inside : f.outside).push_back(e);
    const double t = 1e-9 * static_cast<double>(r.t_real);
    if (!r.camera && out_since < 0) out_since = t;
    if (r.camera) out_since = -1;
    if (out_since >= 0) f.longest_out = std::max(f.longest_out, t - out_since);
    if (i == 0) continue;
    EXPECT_GE(r.t_real, records[i - 1].t_real) << "record " << i << " went back in time";
    if (r.camera != records[i - 1].camera) {
      const Eigen::Vector3d moved = truth(r.t_real) - truth(records[i - 1].t_real);
      f.handover.push_back((r.p - records[i - 1].p - moved).head<2>().norm());
    }
  }
  return f;
}

double largest(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

TEST(IpsdHandover, ARobotLeavingTheCamerasIsCarriedByItsRangesAndHandedBack) {
  IPS_RELEASE_ONLY("TrackFusionSources (tests/fusion) and IpsdRangingSim");
  HandoverRun run = run_handover(
      "ipsd_handover", std::string(kRobot) + kAnchors, "markers:\n  ids:\n    5: {height: 0.15}\n",
      "  height: 0.15\n  tags:\n    - {id: 7, marker: 5}\n", [](const Datagram& d, std::vector<Record>& out) {
        for (const auto& m : d.markers)
          if (m.id == 5) out.push_back({d.capture_realtime_ns + 1000LL * m.dt_us, {m.x, m.y, m.z}, m.camera_mask != 0});
      });
  ASSERT_FALSE(HasFailure());
  const fs::path& dir = run.dir;
  const fs::path& log = run.log;
  const nlohmann::json& status = run.status;
  const sim::Scene& scene = run.scene;
  const std::int64_t epoch = run.epoch;
  const std::vector<Record>& records = run.records;

  // The scene's pose at each record's capture time (its realtime moved to the camera's clock).
  const std::int64_t real_minus_mono = realtime_minus_monotonic_ns();
  const auto truth = [&](std::int64_t t_real) {
    const sim::MarkerPose pose = scene.marker_pose(5, 1e-9 * static_cast<double>(t_real - real_minus_mono - epoch));
    return Eigen::Vector3d(pose.x, pose.y, 0.15);
  };
  const HandoverFigures f = figures(records, truth);
  const auto& [inside, outside, handover, longest_out] = f;
  std::printf(
      "[ handover ] %zu records: %zu by the camera, 2-D p95 %.1f mm; %zu by the ranges alone (longest "
      "stretch %.1f s), p95 %.1f mm; %zu hand-overs, largest step beyond the motion %.1f mm; ranging %s\n",
      records.size(), inside.size(), 1e3 * p95(inside), outside.size(), longest_out, 1e3 * p95(outside),
      handover.size(), 1e3 * largest(handover), status["ranging"].dump().c_str());
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
  EXPECT_NE(run.status_text.find("anchor 1: "), std::string::npos) << run.status_text;
  fs::remove_all(dir);
}

// The same drive by a two-marker body carrying its tag 0.3 m above its origin (ranging.tags[].body):
// out of the camera's view the tag's fixes place the body (heading held), and the body's
// records say so (sources, camera_mask 0).
constexpr const char* kBody = R"(bodies:
  - name: long
    edge: 0.10
    flat: [{id: 7, offset: [0.2, 0, 0.25]}, {id: 8, offset: [-0.2, 0, 0.25]}]
    trajectory: {type: waypoints, points: [[2.4, 2.3], [8.0, 2.3]], speed: 0.3}
tags:
  - {id: 9, body: long, offset: [0.0, 0.0, 0.3]}
)";

TEST(IpsdHandover, ABodyLeavingTheCamerasIsCarriedByItsTagsRanges) {
  IPS_RELEASE_ONLY("BodyTrackRanges (tests/body) and the marker hand-over above");
  std::uint64_t ranged_without_yaw = 0, ranged = 0;
  HandoverRun run =
      run_handover("ipsd_body_handover", std::string(kBody) + kAnchors,
                   "markers:\n  height: 0.25\nbodies:\n  - name: long\n    edge: 0.10\n"
                   "    flat: [{id: 7, offset: [0.2, 0, 0.25]}, {id: 8, offset: [-0.2, 0, 0.25]}]\n",
                   "  height: 0.3\n  tags:\n    - {id: 9, body: long, offset: [0.0, 0.0, 0.3]}\n",
                   [&](const Datagram& d, std::vector<Record>& out) {
                     for (const auto& b : d.bodies)
                       if (b.name == "long") {
                         const bool camera = b.camera_mask != 0;
                         if (!camera) {
                           ++ranged;
                           ranged_without_yaw += !b.has_yaw && b.sources == IPS_WIRE_SOURCE_RANGES;
                         }
                         out.push_back({d.capture_realtime_ns + 1000LL * b.dt_us, {b.x, b.y, b.z}, camera});
                       }
                   });
  ASSERT_FALSE(HasFailure());
  const std::int64_t real_minus_mono = realtime_minus_monotonic_ns();
  const auto truth = [&](std::int64_t t_real) {
    return run.scene.body_pose_at(0, 1e-9 * static_cast<double>(t_real - real_minus_mono - run.epoch)).position;
  };
  const HandoverFigures f = figures(run.records, truth);
  std::printf(
      "[ handover ] body: %zu records: %zu by the camera, 2-D p95 %.1f mm; %zu by the tag's ranges alone (longest "
      "stretch %.1f s), p95 %.1f mm; %zu hand-overs, largest step beyond the motion %.1f mm\n",
      run.records.size(), f.inside.size(), 1e3 * p95(f.inside), f.outside.size(), f.longest_out, 1e3 * p95(f.outside),
      f.handover.size(), 1e3 * largest(f.handover));
  ASSERT_GE(f.inside.size(), 10u) << test::read_file(run.log);
  EXPECT_GT(f.longest_out, 15.0) << "the body must leave the camera's view for a while";
  EXPECT_LT(p95(f.inside), 0.02);
  EXPECT_LT(p95(f.outside), 0.10);
  EXPECT_EQ(ranged_without_yaw, ranged) << "ranges alone: sources = ranges, the heading held";
  ASSERT_GE(f.handover.size(), 2u) << "out of view and back";
  for (double step : f.handover) EXPECT_LT(step, 3 * 0.05) << "a hand-over jumped beyond 3 sigma of a range";
  EXPECT_GT(run.status["fusion_held_for_cameras"].get<int>(), 100)
      << "the fixes under the camera waited for its records";
  fs::remove_all(run.dir);
}

}  // namespace
}  // namespace ips
