// The real ipsd on three unsynchronised synthetic cameras (capture phases 0 / 11 / 23 ms):
// asynchronous fusion against the simulator's truth at each record's capture time, the order
// guarantee with a deliberately late camera, and triangulation without marker heights.
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <thread>

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

// Low, so that the cameras keep most frames on a loaded 2-core machine; with phases 0/11/23 ms
// two of every three frames still find another camera's frame within fusion.window (50 ms).
constexpr double kFps = 10.0;

struct Record {
  MarkerRecord m;
  std::int64_t t_mono_ns;  ///< the record's capture time: header + dt_us
};

class IpsdFusionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("ipsd_fusion_test_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    // Two robots at 1 m/s (known heights in test A), two more at unknown heights.
    std::ofstream(*dir_ / "scene.yaml") << test::published_scene_with(R"(markers:
  - id: 1
    length: 0.20
    height: 0.15
    trajectory: {type: circle, center: [2.4, 1.7], radius: 0.6, speed: 1.0}
  - id: 2
    length: 0.20
    height: 0.10
    trajectory: {type: circle, center: [2.4, 3.0], radius: 0.7, speed: 1.0, clockwise: true}
  - id: 3
    length: 0.20
    height: 0.30
    trajectory: {type: circle, center: [2.2, 2.4], radius: 0.5, speed: 0.3}
  - id: 4
    length: 0.20
    x: 2.7
    y: 2.9
    height: 0.02
    yaw_deg: 30
)");
    test::write_plane_model(*dir_ / "scene.yaml", *dir_ / "model.json");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }

  static std::string camera(const std::string& name, double phase, const std::string& extra = "") {
    return "  - {name: " + name + ", source: synthetic, scene: scene.yaml, fps: " + std::to_string(kFps) +
           ", phase: " + std::to_string(phase) + extra + "}\n";
  }
  // The output port is filled in by run(), which owns the receiver.
  static std::string config(const std::string& markers, const std::string& slow = "", const std::string& all = "",
                            const std::string& fusion = "") {
    std::string c =
        "cameras:\n" + camera("red", 0.0, all) + camera("white", 0.011, all) + camera("black", 0.023, slow + all);
    c += markers + fusion;
    c += "model_file: model.json\n";
    c += "outputs:\n  - {type: unicast, address: 127.0.0.1, port: @PORT@, format: binary}\n";
    c += "status: {interval: 1, socket: " + (*dir_ / "status.sock").string() + "}\n";
    return c;
  }

  struct Run {
    std::vector<Record> records;
    nlohmann::json status;
    std::int64_t epoch = 0;
    std::string log;
    /// The share of the cameras' frames (3 x kFps per second since the epoch) that the daemon
    /// processed: below 1 where a busy machine rendered and detected fewer.
    double frame_coverage = 0;
  };

  // Runs ipsd on `yaml` for `seconds` after the first datagram, and on while `enough` (if given)
  // says the records are not yet enough to judge: a loaded machine under the sanitizers renders
  // few synthetic frames per second, and the test asserts accuracy, not throughput, there. A
  // hard limit of 120 s ends it either way (the ctest timeout is 600 s); the status is read at the end.
  static Run run(const std::string& yaml, double seconds,
                 const std::function<bool(const std::vector<Record>&)>& enough = {}) {
    test::UdpReceiver rx;
    const fs::path cfg = *dir_ / "ipsd.yaml", log = *dir_ / "ipsd.log";
    std::string text = yaml;
    text.replace(text.find("@PORT@"), 6, std::to_string(rx.port));
    std::ofstream(cfg) << text;
    const pid_t pid = test::spawn({test::bin("ipsd"), "--config", cfg.string()}, log);
    const test::ChildGuard guard(pid);
    Run r;
    const std::int64_t start_limit = monotonic_ns() + static_cast<std::int64_t>(30e9 * test::kTimeScale);
    const std::int64_t hard_limit = monotonic_ns() + static_cast<std::int64_t>(120e9);
    std::int64_t end = 0;
    const auto more_wanted = [&] {
      const std::int64_t now = monotonic_ns();
      if (now >= hard_limit) return false;
      if (!end) return now < start_limit;
      return now < end || (enough && !enough(r.records));
    };
    while (more_wanted()) {
      auto bytes = rx.receive(100);
      if (!bytes) continue;
      // Sanitized builds: a little longer, not kTimeScale times (only accuracy and order are
      // asserted there, see below).
      if (!end) end = monotonic_ns() + static_cast<std::int64_t>(seconds * std::min(test::kTimeScale, 2.0) * 1e9);
      const Datagram d = decode_datagram(*bytes);
      for (const auto& m : d.markers) r.records.push_back({m, d.capture_monotonic_ns + 1000LL * m.dt_us});
    }
    r.status = nlohmann::json::parse(test::read_unix_socket((*dir_ / "status.sock").string()));
    r.epoch = r.status["synthetic_epoch_mono_ns"];
    double processed = 0;
    for (const auto& c : r.status["cameras"]) processed += c.value("frames", 0.0);
    r.frame_coverage = processed / (3 * kFps * 1e-9 * static_cast<double>(monotonic_ns() - r.epoch));
    r.log = test::read_file(log);
    return r;
  }

  static fs::path* dir_;
};
fs::path* IpsdFusionTest::dir_ = nullptr;

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double p95(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(v.size()))) - 1];
}

// Per marker, the capture times of the stream never decrease; returns the number of records.
std::size_t expect_per_marker_order(const std::vector<Record>& records) {
  std::map<std::uint32_t, std::int64_t> last;
  std::size_t backwards = 0;
  for (const auto& r : records) {
    auto [it, fresh] = last.try_emplace(r.m.id, r.t_mono_ns);
    if (!fresh && r.t_mono_ns < it->second) ++backwards;
    it->second = std::max(it->second, r.t_mono_ns);
  }
  EXPECT_EQ(backwards, 0u) << "records that went back in capture time";
  return records.size();
}

TEST_F(IpsdFusionTest, MarkersAt1MpsUnsynchronisedCamerasWithinACentimetre) {
  const Run r = run(config("markers:\n  height: 0.0\n  ids:\n    1: {height: 0.15}\n"
                           "    2: {height: 0.10}\n    3: {height: 0.30}\n    4: {height: 0.02}\n"),
                    6.0, [](const std::vector<Record>& records) {
                      // Until there are records enough to judge (asserted below), whatever the
                      // machine's load: a busy one renders fewer synthetic frames per second
                      // (13 fast-marker records in 6 s beside another daemon's test, 120 alone).
                      // Under the sanitizers one comes about every 15 s (7 in 120 s measured):
                      // three are enough to check accuracy and order there.
                      const long fast = std::count_if(records.begin(), records.end(),
                                                      [](const Record& x) { return x.m.id == 1 || x.m.id == 2; });
                      if (test::kTimeScale != 1.0) return fast >= 3;
                      const long several = std::count_if(records.begin(), records.end(), [](const Record& x) {
                        return std::popcount(x.m.camera_mask) >= 2;
                      });
                      return fast > 20 && several > 5;
                    });
  ASSERT_FALSE(r.records.empty()) << r.log;
  expect_per_marker_order(r.records);
  const auto scene = sim::Scene::load(*dir_ / "scene.yaml");
  std::vector<double> fast, several;
  for (const auto& rec : r.records) {
    const double t = 1e-9 * static_cast<double>(rec.t_mono_ns - r.epoch);
    const sim::MarkerPose truth = scene.marker_pose(static_cast<int>(rec.m.id), t);
    const double e = std::hypot(rec.m.x - truth.x, rec.m.y - truth.y);
    if (rec.m.id == 1 || rec.m.id == 2) fast.push_back(e);
    if (std::popcount(rec.m.camera_mask) >= 2) several.push_back(e);
  }
  std::printf(
      "[ ipsd    ] 1 m/s at %.0f fps, phases 0/11/23 ms: 2D error p95 %.2f mm over %zu records (%zu from >= 2 "
      "cameras, p95 %.2f mm); processing latency p50 %s p99 %s ms\n",
      kFps, 1e3 * p95(fast), fast.size(), several.size(), 1e3 * p95(several),
      r.status["processing_latency_ms"]["p50"].dump().c_str(), r.status["processing_latency_ms"]["p99"].dump().c_str());
  ASSERT_FALSE(fast.empty());
  EXPECT_LE(p95(fast), 0.010);
  ASSERT_TRUE(r.status["processing_latency_ms"].contains("p99"));
  ASSERT_TRUE(r.status["capture_latency_ms"].contains("p50"));
  if (test::kTimeScale == 1.0) {
    EXPECT_GT(fast.size(), 20u);
    EXPECT_GT(several.size(), 5u);
    // Capture latency includes the simulated transport (one frame period, 100 ms).
    EXPECT_GE(r.status["capture_latency_ms"]["p50"].get<double>(), 100.0);
  }
}

TEST_F(IpsdFusionTest, ALateCameraOnAStarvedMachineNeverMakesAMarkerGoBackInTime) {
  // It starves the daemon on purpose (both cores spun): under the sanitizers nothing is left.
  IPS_RELEASE_ONLY("TrackFusion.ACameraOlderThanTheWindowIsLeftOut and IpsdFusionTest.MarkersAt1Mps*");
  // black's frames arrive 250 ms after capture, the others' after 100 ms (one frame period);
  // black's stamps are also moved by a timestamp_offset of 4 ms. Meanwhile two threads of
  // this test spin on both cores, so the daemon's threads are starved and delayed at random.
  std::atomic<bool> stop{false};
  std::vector<std::thread> hogs;
  for (int i = 0; i < 2; ++i)
    hogs.emplace_back([&stop] {
      volatile std::uint64_t x = 0;
      while (!stop.load(std::memory_order_relaxed)) x = x + 1;
    });
  const Run r = run(config("markers:\n  height: 0.1\n  ids:\n    1: {height: 0.15}\n"
                           "    2: {height: 0.10}\n    3: {height: 0.30}\n    4: {height: 0.02}\n",
                           ", transport_delay: 0.25, timestamp_offset: 0.004"),
                    5.0);
  stop = true;
  for (auto& h : hogs) h.join();
  ASSERT_FALSE(r.records.empty()) << r.log;
  expect_per_marker_order(r.records);
  // Every record's time is a frame instant: red's (phase 0), white's (11 ms), black's (23 + 4 ms).
  std::map<std::int64_t, int> phases;
  for (const auto& rec : r.records) {
    const std::int64_t in_period = (rec.t_mono_ns - r.epoch) % static_cast<std::int64_t>(1e9 / kFps);
    ++phases[in_period];
    EXPECT_TRUE(in_period == 0 || in_period == 11'000'000 || in_period == 27'000'000) << in_period;
  }
  EXPECT_TRUE(phases.count(27'000'000)) << "no record from black's frames";
  std::printf(
      "[ ipsd    ] late camera, both cores spun by the test: %zu records, none back in time; "
      "%llu observations merged late, %llu too old\n",
      r.records.size(), static_cast<unsigned long long>(r.status["fusion_late"].get<std::uint64_t>()),
      static_cast<unsigned long long>(r.status["fusion_too_old"].get<std::uint64_t>()));
  EXPECT_GT(r.status["fusion_late"].get<std::uint64_t>(), 0u) << r.status.dump();
}

TEST_F(IpsdFusionTest, FixedRateOutputPredictsEveryMarkerToTheTick) {
  IPS_RELEASE_ONLY("TrackFusion.* and Kalman.* (the prediction), IpsdFusionTest.MarkersAt1Mps* (the daemon)");
  // 20 updates/s, each with every marker predicted to the tick; frames arrive 33 ms after
  // capture (a 30 fps USB camera), so the prediction reaches 40-150 ms ahead of the data.
  const Run r = run(config("markers:\n  ids:\n    1: {height: 0.15}\n    2: {height: 0.10}\n"
                           "    3: {height: 0.30}\n    4: {height: 0.02}\n",
                           "", ", transport_delay: 0.033", "fusion: {output_rate: 20}\n"),
                    5.0);
  ASSERT_FALSE(r.records.empty()) << r.log;
  expect_per_marker_order(r.records);
  const auto scene = sim::Scene::load(*dir_ / "scene.yaml");
  std::vector<double> fast, slow;
  std::map<std::int64_t, int> ticks;
  for (const auto& rec : r.records) {
    ++ticks[rec.t_mono_ns];
    const double t = 1e-9 * static_cast<double>(rec.t_mono_ns - r.epoch);
    const sim::MarkerPose truth = scene.marker_pose(static_cast<int>(rec.m.id), t);
    (rec.m.id <= 2 ? fast : slow).push_back(std::hypot(rec.m.x - truth.x, rec.m.y - truth.y));
  }
  // Tick spacing: 50 ms (the median; a loaded machine may delay one).
  std::vector<std::int64_t> gaps;
  for (auto it = ticks.begin(); std::next(it) != ticks.end(); ++it) gaps.push_back(std::next(it)->first - it->first);
  std::sort(gaps.begin(), gaps.end());
  ASSERT_FALSE(gaps.empty());
  EXPECT_NEAR(1e-6 * static_cast<double>(gaps[gaps.size() / 2]), 50.0, 2.0);
  // A starved machine makes the cameras skip frames: markers then miss ticks (their tracks wait
  // for data), and the prediction reaches further. The share of ticks carrying both 1 m/s
  // markers shows how starved this run was.
  const double coverage = static_cast<double>(fast.size()) / (2.0 * static_cast<double>(ticks.size()));
  std::printf(
      "[ ipsd    ] fixed rate 20 Hz: predicted 2D error median %.1f p95 %.1f mm at 1 m/s on 0.6-0.7 m circles "
      "(%zu, %.0f %% of ticks), median %.1f p95 %.1f mm at 0.3 m/s or static (%zu)\n",
      1e3 * median(fast), 1e3 * p95(fast), fast.size(), 100 * coverage, 1e3 * median(slow), 1e3 * p95(slow),
      slow.size());
  // The prediction reaches from the newest frame (10 fps, 33 ms transport) to the tick: 33-183 ms
  // ahead, 100 ms more for each frame a camera skips. Along a 0.6 m circle at 1 m/s a straight
  // line h ahead is off by ~v^2 h^2 / 2r: 1 mm at 33 ms, 28 mm at 183 ms, 67 mm at 283 ms.
  // Holding the last position instead of predicting is off by the travel v h: median 60 mm even
  // with every frame in time. Measured: quiet machine, 97 % of ticks: median 20-23, p95 33-43 mm;
  // three busy loops beside it, 50 % of ticks: median 52, p95 86-90 mm (the CI once: p95 86 mm).
  if (!fast.empty()) {
    const bool starved = coverage < 0.9;
    EXPECT_LE(median(fast), starved ? 0.08 : 0.035);
    EXPECT_LE(p95(fast), starved ? 0.15 : 0.06);
  }
  if (!slow.empty()) {
    EXPECT_LE(median(slow), 0.005);
    EXPECT_LE(p95(slow), 0.02);
  }
}

TEST_F(IpsdFusionTest, TwoCamerasTriangulateMarkersWithoutHeights) {
  // No markers section: no heights. On until two markers are triangulated, whatever the
  // machine's load: a ray is moved to another camera's instant by its own camera's velocity (2
  // frames within fusion.velocity_span), and beside 4 busy loops the cameras render 3-6 of their
  // 10 frames/s, 300 ms late: 6 s gave 0-5 records, 97-120 s gave 34-45 (quiet: 68 in 6 s).
  const Run r = run(config(""), 6.0, [](const std::vector<Record>& records) {
    if (test::kTimeScale != 1.0) return true;  // sanitizers: what comes in 12 s is checked
    std::map<std::uint32_t, int> per_marker;
    for (const Record& x : records) ++per_marker[x.m.id];
    return std::count_if(per_marker.begin(), per_marker.end(), [](const auto& m) { return m.second >= 3; }) >= 2;
  });
  // Under the sanitizers the cameras skip most frames, so they rarely have two recent frames
  // to move a ray with and there may be nothing to triangulate: what comes is still checked.
  if (test::kTimeScale == 1.0 && r.frame_coverage > 0.6) {
    ASSERT_FALSE(r.records.empty()) << r.log;
  }
  expect_per_marker_order(r.records);
  const auto scene = sim::Scene::load(*dir_ / "scene.yaml");
  std::vector<double> errors;
  std::map<std::uint32_t, int> per_marker;
  for (const auto& rec : r.records) {
    EXPECT_GE(std::popcount(rec.m.camera_mask), 2) << "one camera without a height must not be reported";
    const double t = 1e-9 * static_cast<double>(rec.t_mono_ns - r.epoch);
    const sim::MarkerPose truth = scene.marker_pose(static_cast<int>(rec.m.id), t);
    errors.push_back(
        std::sqrt(std::pow(rec.m.x - truth.x, 2) + std::pow(rec.m.y - truth.y, 2) + std::pow(rec.m.z - truth.z, 2)));
    ++per_marker[rec.m.id];
  }
  std::printf(
      "[ ipsd    ] triangulated without heights: 3D error p95 %.2f mm over %zu records, markers seen %zu, %.0f %% of "
      "the frames processed\n",
      1e3 * p95(errors), errors.size(), per_marker.size(), 100 * r.frame_coverage);
  if (!errors.empty()) {
    EXPECT_LE(p95(errors), 0.020);
  }
  // Where the machine kept up. Starved (ctest -j2 beside 4 busy loops: 10 records of the static
  // marker in 120 s), what came is still checked above.
  if (test::kTimeScale == 1.0 && r.frame_coverage > 0.6) {
    EXPECT_GE(per_marker.size(), 2u);
  }
}

}  // namespace
}  // namespace ips
