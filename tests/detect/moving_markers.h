// Test helpers for tracking: markers moving on the floor of the published lab, rendered
// by the simulator as a camera delivers them (JPEG q90 4:2:0), with their exact truth.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "ips/capture/jpeg_decoder.h"
#include "ips/core/observation.h"
#include "ips/sim/renderer.h"

namespace ips_test {

using ips::sim::CameraRenderer;
using ips::sim::MarkerPose;
using ips::sim::PlacedMarker;
using ips::sim::Scene;
using ips::sim::SceneMarker;

inline const std::filesystem::path kScene = std::filesystem::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml";
constexpr double kFps = 30.0;

inline Scene test_scene() {
  Scene s = Scene::load(kScene);
  s.markers.clear();
  s.render.noise_sigma = 2.0;
  return s;
}

// A marker moving on the floor at constant velocity (m/s) and turn rate (rad/s); `from` /
// `until`: the frames it is in the scene; `jump_at`: from that frame on it is displaced by
// (jump_x, jump_y) metres at once (picked up and put down elsewhere between two frames).
struct Mover {
  int id = 0;
  double length = 0.20;
  double x = 0, y = 0, vx = 0, vy = 0, yaw = 0, turn = 0;
  int from = 0, until = 1 << 30;
  int jump_at = -1;
  double jump_x = 0, jump_y = 0;
  bool present(int f) const { return f >= from && f < until; }
  MarkerPose pose(int f) const {
    const double t = f / kFps;
    MarkerPose p{x + vx * t, y + vy * t, 0.01, yaw + turn * t};
    if (jump_at >= 0 && f >= jump_at) {
      p.x += jump_x;
      p.y += jump_y;
    }
    return p;
  }
};

struct Sequence {
  const CameraRenderer& r;
  std::vector<Mover> movers;
  int restart_rows = 0;  ///< restart markers every this many MCU rows (0: none)
  // Frame f as a camera delivers it (JPEG q90 4:2:0, decoded to grey) and its truth.
  std::vector<std::uint8_t> jpeg(int f, std::vector<ips::sim::MarkerTruth>& truth) const {
    std::vector<PlacedMarker> placed;
    truth.clear();
    for (const auto& m : movers) {
      if (!m.present(f)) continue;
      SceneMarker sm;
      sm.id = m.id;
      sm.length = m.length;
      placed.push_back({sm, {m.pose(f)}});
      const auto t = r.truth_of(sm, m.pose(f));
      EXPECT_TRUE(t.visible) << "marker " << m.id << " frame " << f;
      truth.push_back(t);
    }
    cv::Mat gray;
    r.render_markers(placed, gray, static_cast<std::uint64_t>(f));
    return ips::sim::encode_jpeg(gray, 90, true, restart_rows);
  }
  cv::Mat frame(int f, std::vector<ips::sim::MarkerTruth>& truth) const {
    ips::JpegDecoder decoder;
    cv::Mat gray;
    EXPECT_TRUE(decoder.decode_gray(jpeg(f, truth), gray));
    return gray;
  }
};

inline double corner_error(const ips::MarkerDetection& d, const ips::sim::MarkerTruth& t) {
  double e = 0;
  for (std::size_t k = 0; k < 4; ++k)
    e = std::max(e, std::hypot(d.corners_px[k].x - t.corners_px[k].x, d.corners_px[k].y - t.corners_px[k].y));
  return e;
}

inline double side_px(const ips::sim::MarkerTruth& t) {
  double s = 0;
  for (std::size_t k = 0; k < 4; ++k)
    s += std::hypot(t.corners_px[(k + 1) % 4].x - t.corners_px[k].x, t.corners_px[(k + 1) % 4].y - t.corners_px[k].y);
  return s / 4;
}

inline const ips::MarkerDetection* find(const std::vector<ips::MarkerDetection>& found, int id) {
  for (const auto& d : found)
    if (d.id == id) return &d;
  return nullptr;
}

// Every reported marker is a true one at its true corners (nothing the truth does not have).
inline void expect_true_markers(const std::vector<ips::MarkerDetection>& found,
                                const std::vector<ips::sim::MarkerTruth>& truth, int f) {
  for (const auto& d : found) {
    const auto t = std::find_if(truth.begin(), truth.end(), [&](const auto& x) { return x.id == d.id; });
    ASSERT_NE(t, truth.end()) << "frame " << f << ": marker " << d.id << " is not in the scene";
    // 0.5 px for 20 cm markers; 1 px for 7.5 cm ones at the edge of the view (24-35 px).
    EXPECT_LT(corner_error(d, *t), side_px(*t) > 40 ? 0.5 : 1.0) << "frame " << f << " marker " << d.id;
  }
}

}  // namespace ips_test
