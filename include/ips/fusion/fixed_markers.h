// The bumped-camera check: markers declared fixed (markers.ids.<id>.fixed, a reference left on
// the floor) are compared, per camera, with where that camera alone maps them (its own model,
// before fusion with the other cameras). A camera whose recent error exceeds the threshold
// has probably moved since its model was fitted or surveyed.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ips/fusion/fusion.h"

namespace ips {

/// A camera's error on one fixed marker crossed the threshold (up: kMoved) or came back
/// under it (kBack).
struct FixedMarkerEvent {
  enum class Kind { kMoved, kBack };
  Kind kind = Kind::kMoved;
  int camera_index = -1;
  int id = -1;
  double error_m = 0;  ///< the robust error that crossed, metres
};

/// One (camera, fixed marker) pair as the status shows it.
struct FixedMarkerReading {
  int camera_index = -1;
  int id = -1;
  double error_m = 0;       ///< median horizontal distance over the window, metres
  std::size_t samples = 0;  ///< observations in the window
  bool seen = false;        ///< observed within the window before `now`
  bool moved = false;       ///< currently over the threshold (a warning was logged)
};

class FixedMarkerMonitor {
 public:
  struct Options {
    double warn_m = 0.03;         ///< fusion.fixed_marker_warn
    double window_s = 1.0;        ///< the median covers this much of each pair's recent observations
    std::size_t min_samples = 3;  ///< no verdict on fewer observations (one bad frame is no bump)
    double back_ratio = 0.8;      ///< "back" below back_ratio * warn_m: no flapping at the threshold
  };

  /// `fixed`: surveyed world position by marker id.
  FixedMarkerMonitor(std::map<int, Eigen::Vector3d> fixed, Options options);

  /// Replaces positions and threshold; the history is kept only when nothing changed.
  void configure(std::map<int, Eigen::Vector3d> fixed, Options options);

  /// One camera frame's mapped observations (before fusion). Returns the threshold crossings.
  /// Observations without a world position (height unknown: ray only) are ignored.
  std::vector<FixedMarkerEvent> add(const FrameObservations& batch);

  /// Every pair seen so far, ordered by camera then id. Thread-safe against add().
  std::vector<FixedMarkerReading> readings(std::int64_t now_mono_ns) const;

  bool empty() const { return fixed_.empty(); }

 private:
  struct Pair {
    std::deque<std::pair<std::int64_t, double>> errors;  // (capture time, distance), oldest first
    bool moved = false;
    double median = 0;
  };
  static double median_of(const std::deque<std::pair<std::int64_t, double>>& errors);

  std::map<int, Eigen::Vector3d> fixed_;
  Options options_;
  mutable std::mutex mutex_;
  std::map<std::pair<int, int>, Pair> pairs_;  // (camera index, marker id)
};

}  // namespace ips
