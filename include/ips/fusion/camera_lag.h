// How late the cameras' frames reach fusion: capture to fusion, the largest over the last few
// seconds. Fusion holds other sources back while a camera has placed an object recently
// (TrackFusionOptions::camera_hold_s); on a busy machine the frames can arrive later than that
// hold, and the ranges would then take a camera-seen robot over. The hold follows this lag.
#pragma once

#include <cstdint>
#include <deque>
#include <utility>

namespace ips {

class CameraLag {
 public:
  static constexpr std::int64_t kSpanNs = 5'000'000'000;  ///< lags older than this are forgotten

  /// A camera frame captured at t_capture_ns reached fusion at t_fusion_ns (CLOCK_MONOTONIC).
  void add(std::int64_t t_capture_ns, std::int64_t t_fusion_ns);
  /// The largest lag within kSpanNs before the newest arrival (ns; 0 before any).
  std::int64_t max_ns() const;

 private:
  std::deque<std::pair<std::int64_t, std::int64_t>> lags_;  // (arrival, lag), arrival order; decreasing lags
};

}  // namespace ips
