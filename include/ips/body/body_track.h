// Asynchronous fusion of rigid bodies (the daemon's, like ips/fusion/track_fusion.h for markers):
// each camera frame's body observations (ips/body/body_estimate.h) produce at once one pose per
// body that frame saw, at that frame's capture time T, fused over all the body's markers and
// every camera that saw it within `window_s` before T. Another camera's older views are moved
// forward to T by the body's own velocity and turned by its own yaw rate about its origin
// (both from its recent published poses; a vertical axis of rotation), then the
// views of the instant go through BodyEstimator::fuse (cube faces told apart, baseline yaw,
// the configured method).
//
// Velocity: each published pose carries the body's velocity and yaw rate, the newest minus the
// oldest of its published poses within `velocity_span_s` (with the newest one) over their time
// apart: the mean over the span, so it lags a turn by half the span. The first pose has none.
//
// Order: a body is published only at a capture time >= its last published time; a frame that
// arrives late (older than that) is merged into the history for later outputs but publishes
// nothing for that body (counted as `late`). Not thread-safe: owned by the fusion thread.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <span>
#include <vector>

#include "ips/body/body_estimate.h"

namespace ips {

/// Bodies are fused over the same time windows as markers (fusion.window, velocity_span, history).
struct BodyTrackOptions : FusionTimeWindows {};

class BodyTrack {
 public:
  BodyTrack(std::vector<BodyDef> bodies, const BodyTrackOptions& options = {});

  const std::vector<BodyDef>& bodies() const { return estimator_.bodies(); }

  /// One camera frame's body observations, all captured at t_mono_ns by `camera_index`.
  /// Appends the fused pose at t_mono_ns of every body the frame saw that may be published
  /// (see "Order"), sorted by body index.
  void add(int camera_index, std::int64_t t_mono_ns, std::int64_t t_real_ns,
           std::span<const BodyObservation> observations, const FusionMethod& method, std::vector<FusedBody>& out);

  /// Fixed-rate output: every body's newest pose if it is at most history_s older than
  /// t_mono_ns (its own capture time stays; it never goes back).
  void latest(std::int64_t t_mono_ns, std::vector<FusedBody>& out) const;

  std::uint64_t late() const { return late_; }

  /// Takes over `previous`'s last published pose of every body of the same name (a reload:
  /// each body's stream keeps never going back in time).
  void continue_after(const BodyTrack& previous);

 private:
  struct Frame {
    std::int64_t t_ns = 0;
    std::vector<BodyObservation> views;
  };
  struct Track {
    std::map<int, std::deque<Frame>> by_camera;  // time-ordered per camera
    std::int64_t newest_ns = 0;
    bool published = false;
    FusedBody last;  // the last published pose
    struct Pose {
      std::int64_t t_ns = 0;
      Eigen::Vector3d position;
      bool has_yaw = false;
      double yaw = 0.0;
    };
    std::deque<Pose> path;  // recent published poses, within the velocity span
  };
  static Eigen::Vector3d velocity(const Track& track);
  static bool yaw_rate(const Track& track, double& rate);  // rad/s over the span; false without two yaws
  static void move_forward(BodyObservation& o, const Eigen::Vector3d& shift, double turn);
  /// The body's velocity and yaw rate from its path (the newest pose included).
  static void set_velocity(const Track& track, FusedBody& f);

  BodyEstimator estimator_;
  BodyTrackOptions options_;
  std::vector<Track> tracks_;
  std::uint64_t late_ = 0;
};

}  // namespace ips
