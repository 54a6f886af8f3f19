// Per-frame cost of the perception front end on rendered 1920x1080 JPEG (q90, 4:2:0 colour,
// like a USB camera's MJPEG) frames with 0, 1 and 5 markers (20 cm, 2.1 m below the red
// camera of the published layout; the "5s" case: 5 markers of 7.5 cm, 24-45 px, over the
// whole view): MJPEG decode, detection, locate; median and p95 over the
// frames, single-threaded (cv::setNumThreads(1)). Two pipelines on the same frames:
//   ours:      greyscale turbojpeg decode -> ips::Detector (downscaled detection, fewer
//              threshold passes, full-resolution edge-line corner refinement with the camera model,
//              cell verification) -> ips::locate_marker
//   reference: the published sequence: cv::imdecode colour -> cvtColor grey -> detectMarkers
//              with default parameters -> cornerSubPix (winSize 3x3) ->
//              cv::fisheye::undistortPoints
//              -> depth formula
// Also reports detection agreement with the truth (markers found, corner error), and two
// figures that bound what is possible on the machine:
//   decode floor: the luma decoded at 1/8 scale (DC coefficients only). Huffman decoding of
//              the whole bitstream is still paid there, and every full-frame decode pays it;
//   reference detectMarkers with OpenCV's own threads (wall time), as a Python program that
//              does not set the thread count runs it.
// Times are per-thread CPU time, milliseconds, except where "wall" is said.
// Tracked cases "1t" and "5t": 1 and 5 markers moving at up to 1 m/s, a sequence of
// >= 100 frames at 30 fps; three pipelines on the same frames: "tracked" (DetectionTracker with
// partial JPEG decodes of the ROIs; full decode + search on its full-search frames and
// fallbacks), "ours-full" (the full search every frame) and the reference. Per-frame CPU.
// Usage: bench_perception [frames_per_case=40] [scene.yaml] [tracked_frames=150]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/capture/jpeg_region_decoder.h"
#include "ips/detect/detector.h"
#include "ips/detect/tracker.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/sim/renderer.h"

namespace {

// Time is this thread's CPU time (CLOCK_THREAD_CPUTIME_ID): the cost on one core, which
// stays meaningful when other processes share the machine (wall time would count the time
// the thread waits for a core).
struct Clock {
  using time_point = double;
  static double now() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
  }
};
double ms_since(double t0) { return Clock::now() - t0; }

struct Stats {
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  double pct(double p) const {
    if (v.empty()) return 0;
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    return s[std::min(s.size() - 1, static_cast<std::size_t>(p * static_cast<double>(s.size() - 1) + 0.5))];
  }
};

struct Case {
  std::vector<std::vector<std::uint8_t>> jpegs;
  std::vector<std::vector<ips::sim::MarkerTruth>> truth;
};

struct Result {
  Stats decode, detect, locate, total;
  Stats decode_floor;     // 1/8-scale luma decode (ours only)
  Stats detect_threaded;  // default detectMarkers on OpenCV's threads, wall (reference only)
  int expected = 0, found = 0, extra = 0;
  Stats corner_err;
  std::vector<std::vector<ips::MarkerDetection>> found_per_frame;  // tracked cases only
};

// Tracked against full search on the same frames: markers found by one and not the
// other, and the largest distance between their corners of the same marker.
struct Agreement {
  int differing = 0;
  double max_corner_diff = 0;
};
Agreement agreement(const Result& a, const Result& b) {
  Agreement g;
  for (std::size_t f = 0; f < a.found_per_frame.size() && f < b.found_per_frame.size(); ++f) {
    const auto& fa = a.found_per_frame[f];
    const auto& fb = b.found_per_frame[f];
    g.differing += static_cast<int>(fa.size() > fb.size() ? fa.size() - fb.size() : fb.size() - fa.size());
    for (const auto& d : fa) {
      const auto it = std::find_if(fb.begin(), fb.end(), [&](const auto& e) { return e.id == d.id; });
      if (it == fb.end()) {
        ++g.differing;
        continue;
      }
      for (std::size_t k = 0; k < 4; ++k)
        g.max_corner_diff = std::max(g.max_corner_diff, std::hypot(d.corners_px[k].x - it->corners_px[k].x,
                                                                   d.corners_px[k].y - it->corners_px[k].y));
    }
  }
  return g;
}

void score(const std::vector<ips::MarkerDetection>& found, const std::vector<ips::sim::MarkerTruth>& truth, Result& r) {
  for (const auto& t : truth) {
    ++r.expected;
    for (const auto& d : found) {
      if (d.id != t.id) continue;
      ++r.found;
      for (std::size_t i = 0; i < 4; ++i) {
        r.corner_err.add(std::hypot(d.corners_px[i].x - t.corners_px[i].x, d.corners_px[i].y - t.corners_px[i].y));
      }
      break;
    }
  }
  for (const auto& d : found) {
    bool known = false;
    for (const auto& t : truth) known = known || t.id == d.id;
    r.extra += known ? 0 : 1;
  }
}

// The published sequence of calls on every frame of `c` (markers of edge `length`).
Result reference(const Case& c, const ips::CameraModel& cam, double length, int threads_available) {
  Result ref;
  auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100);
  auto params = cv::aruco::DetectorParameters::create();
  const cv::Mat K(cam.K()), D(cam.D());
  for (std::size_t f = 0; f < c.jpegs.size(); ++f) {
    auto t0 = Clock::now();
    const cv::Mat bgr = cv::imdecode(c.jpegs[f], cv::IMREAD_COLOR);
    const double t_dec = ms_since(t0);
    t0 = Clock::now();
    cv::Mat gray;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(gray, dict, corners, ids, params);
    for (auto& q : corners) {
      cv::cornerSubPix(gray, q, cv::Size(3, 3), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 30, 0.001));
    }
    const double t_det = ms_since(t0);
    t0 = Clock::now();
    double sink = 0;
    for (const auto& q : corners) {
      std::vector<cv::Point2d> in(q.begin(), q.end()), out;
      cv::fisheye::undistortPoints(in, out, K, D);
      double per = 0;
      for (int i = 0; i < 4; ++i)
        per += cv::norm(out[static_cast<std::size_t>((i + 1) % 4)] - out[static_cast<std::size_t>(i)]);
      sink += 4 * length / per;
    }
    const double t_loc = ms_since(t0);
    if (sink < 0) std::printf(" ");
    ref.decode.add(t_dec);
    ref.detect.add(t_det);
    ref.locate.add(t_loc);
    ref.total.add(t_dec + t_det + t_loc);
    std::vector<ips::MarkerDetection> found;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      ips::MarkerDetection d;
      d.id = ids[i];
      for (std::size_t k = 0; k < 4; ++k) d.corners_px[k] = {corners[i][k].x, corners[i][k].y};
      found.push_back(d);
    }
    score(found, c.truth[f], ref);

    cv::setNumThreads(threads_available);
    const auto w0 = std::chrono::steady_clock::now();
    cv::aruco::detectMarkers(gray, dict, corners, ids, params);
    ref.detect_threaded.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count());
    cv::setNumThreads(1);
  }
  return ref;
}

// A tracked case: `n_markers` 20 cm markers moving on the floor under the red camera at
// up to 1 m/s, one lane each (0.34 m apart: they never overlap), bouncing at the ends, turning
// at 0.5 rad/s; 30 fps. Frames are rendered once; ours is run twice on them (tracking with
// partial decodes, and the full search every frame), the reference once.
Case moving_case(const ips::sim::CameraRenderer& renderer, int n_markers, int frames, int restart_rows = 0) {
  Case c;
  const auto& C = renderer.camera().position;
  const double speeds[] = {1.0, 0.8, 0.6, 0.9, 0.7};
  for (int f = 0; f < frames; ++f) {
    const double t = f / 30.0;
    std::vector<ips::sim::PlacedMarker> placed;
    std::vector<ips::sim::MarkerTruth> truth;
    for (int i = 0; i < n_markers; ++i) {
      ips::sim::SceneMarker m;
      m.id = 3 + 11 * i;
      m.length = 0.20;
      const double v = speeds[i % 5];
      // Triangle wave over [-1.2, 1.2] m along x; the single marker also crosses in y.
      const double span = 2.4, path = std::fmod(v * t + 0.37 * span * i, 2 * span);
      const double x = C.x() - span / 2 + (path < span ? path : 2 * span - path);
      const double lane = n_markers == 1 ? 0.5 * std::sin(2.0 * t) : (i - (n_markers - 1) / 2.0) * 0.34;
      const ips::sim::MarkerPose pose{x, C.y() + lane, 0.01, 0.5 * t + i};
      placed.push_back({m, {pose}});
      truth.push_back(renderer.truth_of(m, pose));
    }
    cv::Mat gray;
    renderer.render_markers(placed, gray, static_cast<std::uint64_t>(5000 + f));
    c.jpegs.push_back(ips::sim::encode_jpeg(gray, 90, true, restart_rows));
    c.truth.push_back(truth);
  }
  return c;
}

// Ours with tracking on every frame of `c`, in order: the plan's ROIs decoded (partial
// decode) and searched, the full decode + search on full-search frames and fallbacks.
Result ours_tracked(const Case& c, const ips::CameraModel& cam, double length, Stats& partial_decode,
                    ips::DetectionTracker::Counters& counters) {
  Result r;
  ips::JpegDecoder decoder;
  ips::JpegRegionDecoder region;
  ips::Detector detector;
  ips::DetectionTracker tracker;
  cv::Mat gray;
  for (std::size_t f = 0; f < c.jpegs.size(); ++f) {
    auto t0 = Clock::now();
    const ips::TrackPlan plan = tracker.plan(cv::Size(1920, 1080));
    if (plan.full ? !decoder.decode_gray(c.jpegs[f], gray) : !region.decode(c.jpegs[f], gray, plan.rois)) std::exit(1);
    double t_dec = ms_since(t0);
    if (!plan.full) partial_decode.add(t_dec);
    t0 = Clock::now();
    std::vector<ips::MarkerDetection> found;
    double t_det = 0;
    // The periodic search for new markers, or a marker lost: after the tracked ones.
    if (!tracker.detect(detector, gray, plan, &cam, found) || plan.acquire) {
      t_det += ms_since(t0);
      t0 = Clock::now();
      if (!plan.full && !decoder.decode_gray(c.jpegs[f], gray)) std::exit(1);
      t_dec += ms_since(t0);
      t0 = Clock::now();
      for (auto& d : tracker.acquire(detector, gray, &cam)) found.push_back(d);
    }
    t_det += ms_since(t0);
    t0 = Clock::now();
    double sink = 0;
    for (const auto& d : found) sink += ips::locate_marker(d, cam, length).p_cam.z();
    const double t_loc = ms_since(t0);
    if (sink < 0) std::printf(" ");
    r.decode.add(t_dec);
    r.detect.add(t_det);
    r.locate.add(t_loc);
    r.total.add(t_dec + t_det + t_loc);
    score(found, c.truth[f], r);
    r.found_per_frame.push_back(found);
  }
  counters = tracker.counters();
  return r;
}

// What the partial decode still pays for rows it skips: a baseline JPEG without restart
// markers must be Huffman-decoded up to the first row wanted. Per frame of `c`, median CPU ms
// of JpegRegionDecoder on: the whole frame; the top MCU row only (nothing skipped, decoding
// stops after it); the bottom MCU row only (every row above skipped: Huffman only, no IDCT).
void skip_costs(const Case& c, const char* label) {
  ips::JpegRegionDecoder region;
  Stats whole, top, bottom;
  cv::Mat gray;
  for (const auto& jpeg : c.jpegs) {
    auto t0 = Clock::now();
    if (!region.decode(jpeg, gray, {})) std::exit(1);
    whole.add(ms_since(t0));
    t0 = Clock::now();
    if (!region.decode(jpeg, gray, {cv::Rect(0, 0, 1920, 16)})) std::exit(1);
    top.add(ms_since(t0));
    t0 = Clock::now();
    if (!region.decode(jpeg, gray, {cv::Rect(0, 1080 - 16, 1920, 16)})) std::exit(1);
    bottom.add(ms_since(t0));
  }
  const double skipped = bottom.pct(0.5) - top.pct(0.5);
  std::printf(
      "%-7s           | partial decode (JpegRegionDecoder) median: whole frame %.2f; top MCU row only %.2f; "
      "bottom MCU row only %.2f -> skipping the 67 rows above costs %.2f (%.3f per MCU row, %.0f %% of a "
      "whole decode): the Huffman decoding a restart-marker stream would let a decoder jump over\n",
      label, whole.pct(0.5), top.pct(0.5), bottom.pct(0.5), skipped, skipped / 67.0, 100.0 * skipped / whole.pct(0.5));
}

// Ours without tracking: full decode + full search on every frame. `decode_floor`: also time a
// 1/8-scale decode of each frame (Huffman decoding only), outside the totals.
Result ours_full(const Case& c, const ips::CameraModel& cam, double length, bool decode_floor = false) {
  Result r;
  ips::JpegDecoder decoder;
  ips::Detector detector;
  cv::Mat gray;
  for (std::size_t f = 0; f < c.jpegs.size(); ++f) {
    auto t0 = Clock::now();
    if (!decoder.decode_gray(c.jpegs[f], gray)) std::exit(1);
    const double t_dec = ms_since(t0);
    t0 = Clock::now();
    const auto found = detector.detect(gray, &cam);
    const double t_det = ms_since(t0);
    t0 = Clock::now();
    double sink = 0;
    for (const auto& d : found) sink += ips::locate_marker(d, cam, length).p_cam.z();
    const double t_loc = ms_since(t0);
    if (sink < 0) std::printf(" ");
    r.decode.add(t_dec);
    r.detect.add(t_det);
    r.locate.add(t_loc);
    r.total.add(t_dec + t_det + t_loc);
    score(found, c.truth[f], r);
    r.found_per_frame.push_back(found);
    if (decode_floor) {
      cv::Mat eighth;
      t0 = Clock::now();
      if (!decoder.decode_gray(c.jpegs[f], eighth, 8)) std::exit(1);
      r.decode_floor.add(ms_since(t0));
    }
  }
  return r;
}

double mean(const Stats& s) {
  double m = 0;
  for (double x : s.v) m += x / static_cast<double>(s.v.size());
  return m;
}

void print_row(const char* label, const char* name, const Result& r) {
  std::printf(
      "%-7s %-9s | %7.2f / %7.2f | %7.2f / %7.2f | %7.3f / %7.3f | %7.2f / %7.2f | %4d/%-4d "
      "%5d | %.3f / %.3f\n",
      label, name, r.decode.pct(0.5), r.decode.pct(0.95), r.detect.pct(0.5), r.detect.pct(0.95), r.locate.pct(0.5),
      r.locate.pct(0.95), r.total.pct(0.5), r.total.pct(0.95), r.found, r.expected, r.extra, r.corner_err.pct(0.5),
      r.corner_err.pct(1.0));
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(5, std::atoi(argv[1])) : 40;
  const int tracked_frames_arg = argc > 3 ? std::atoi(argv[3]) : 150;
  const std::string scene_path = argc > 2 ? argv[2] : std::string(IPS_SOURCE_DIR) + "/config/scenes/ou2023.yaml";
  const int threads_available = cv::getNumThreads();
  cv::setNumThreads(1);
  ips::sim::Scene scene = ips::sim::Scene::load(scene_path);
  scene.markers.clear();
  scene.render.noise_sigma = 2.0;
  ips::sim::CameraRenderer renderer(scene, scene.camera_index("red"));
  const ips::CameraModel& cam = renderer.camera().model;
  const auto& C = renderer.camera().position;

  std::mt19937 rng(42);
  std::uniform_real_distribution<double> uni(0, 1);
  std::printf(
      "bench_perception: %d frames per case, 1920x1080 JPEG q90 4:2:0, red camera, single thread, "
      "thread CPU time\n",
      frames);
  std::printf(
      "%-7s %-9s | %-17s | %-17s | %-17s | %-17s | found/expected extra | corner err px "
      "median/max\n",
      "markers", "pipeline", "decode med/p95 ms", "detect med/p95", "locate med/p95", "total med/p95");
  // The last case: 5 small markers (7.5 cm, 24-45 px) spread over the whole view, where the
  // fisheye squeezes them most (found at half scale and read at full resolution).
  for (const auto& [n_markers, length] : {std::pair{0, 0.20}, {1, 0.20}, {5, 0.20}, {5, 0.075}}) {
    const bool small = length < 0.1;
    char label[16];
    std::snprintf(label, sizeof label, small ? "%ds" : "%d", n_markers);
    Case c;
    for (int f = 0; f < frames; ++f) {
      std::vector<ips::sim::PlacedMarker> placed;
      std::vector<ips::sim::MarkerTruth> truth;
      int tries = 0;
      while (static_cast<int>(placed.size()) < n_markers && tries++ < 1000) {
        ips::sim::SceneMarker m;
        m.id = static_cast<int>(placed.size()) * 17 + f % 7;
        m.length = length;
        const ips::sim::MarkerPose pose{C.x() + (uni(rng) - 0.5) * (small ? 3.6 : 2.6),
                                        C.y() + (uni(rng) - 0.5) * (small ? 2.0 : 1.4), uni(rng) * 0.2,
                                        uni(rng) * 6.283};
        bool clear = true;
        for (const auto& p : placed)
          clear = clear && std::hypot(p.poses[0].x - pose.x, p.poses[0].y - pose.y) > 2 * length;
        const auto t = renderer.truth_of(m, pose);
        if (!clear || !t.visible) continue;
        placed.push_back({m, {pose}});
        truth.push_back(t);
      }
      cv::Mat gray;
      renderer.render_markers(placed, gray, static_cast<std::uint64_t>(f + 100 * n_markers + (small ? 1000 : 0)));
      c.jpegs.push_back(ips::sim::encode_jpeg(gray, 90, true));
      c.truth.push_back(truth);
    }
    double bytes = 0;
    for (const auto& j : c.jpegs) bytes += static_cast<double>(j.size());

    // Ours.
    const Result ours = ours_full(c, cam, length, /*decode_floor=*/true);
    // Reference: the published sequence of calls.
    Result ref = reference(c, cam, length, threads_available);
    print_row(label, "ours", ours);
    print_row(label, "reference", ref);
    std::printf(
        "%-7s           | JPEG %.0f kB mean; decode floor (1/8-scale luma: Huffman decoding only) "
        "%.2f / %.2f; reference detectMarkers on %d OpenCV threads, wall %.2f / %.2f\n",
        label, bytes / static_cast<double>(c.jpegs.size()) / 1000.0, ours.decode_floor.pct(0.5),
        ours.decode_floor.pct(0.95), threads_available, ref.detect_threaded.pct(0.5), ref.detect_threaded.pct(0.95));
  }
  // Tracked cases: markers moving at up to 1 m/s, >= 100 frames at 30 fps.
  const int tracked_frames = std::max(100, tracked_frames_arg);
  for (int n_markers : {1, 5}) {
    char label[16];
    std::snprintf(label, sizeof label, "%dt", n_markers);
    const Case c = moving_case(renderer, n_markers, tracked_frames);
    Stats partial;
    ips::DetectionTracker::Counters counters;
    const Result tracked = ours_tracked(c, cam, 0.20, partial, counters);
    const Result full = ours_full(c, cam, 0.20);
    const Result ref = reference(c, cam, 0.20, threads_available);
    print_row(label, "tracked", tracked);
    print_row(label, "ours-full", full);
    print_row(label, "reference", ref);
    std::printf(
        "%-7s           | %d frames: %llu full searches (%llu fallbacks); partial decode med/p95 %.2f / %.2f; "
        "mean total tracked %.2f, full %.2f, reference %.2f; reference/tracked median %.1fx\n",
        label, tracked_frames, static_cast<unsigned long long>(counters.full_searches),
        static_cast<unsigned long long>(counters.fallbacks), partial.pct(0.5), partial.pct(0.95), mean(tracked.total),
        mean(full.total), mean(ref.total), ref.total.pct(0.5) / tracked.total.pct(0.5));
    const Agreement g = agreement(tracked, full);
    std::printf(
        "%-7s           | tracked vs full search on the same frames: %d markers differ, corners within %.4f px; "
        "%llu markers found from their predicted corners alone, %llu ROIs searched\n",
        label, g.differing, g.max_corner_diff, static_cast<unsigned long long>(counters.predicted),
        static_cast<unsigned long long>(counters.roi_searches));
    skip_costs(c, label);
    // The same frames with a restart marker every MCU row, as some cameras send: the region
    // decode cuts the ROIs' rows out and decodes nothing above them.
    std::snprintf(label, sizeof label, "%dt-rst", n_markers);
    const Case rst = moving_case(renderer, n_markers, tracked_frames, 1);
    Stats rst_partial;
    const Result rst_tracked = ours_tracked(rst, cam, 0.20, rst_partial, counters);
    print_row(label, "tracked", rst_tracked);
    std::printf("%-7s           | partial decode med/p95 %.2f / %.2f; mean total tracked %.2f\n", label,
                rst_partial.pct(0.5), rst_partial.pct(0.95), mean(rst_tracked.total));
    skip_costs(rst, label);
  }
  return 0;
}
