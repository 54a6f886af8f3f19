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
// oldest of its published poses over their time apart, the oldest being the newest pose at or
// before `velocity_span_s` ago (or the oldest within twice that): the mean over about the span,
// so it lags a turn by half the span. The first pose has none.
//
// Order: a body is published only at a capture time >= its last published time; a frame that
// arrives late (older than that) is merged into the history for later outputs but publishes
// nothing for that body (counted as `late`).
//
// Ranges: a ranging tag on a body (config ranging.tags[].body) gives fixes of the tag
// (add_fix). Where no camera has placed the body within the camera hold before the fix, the
// fix places it: the tag's offset turned by the body's last published orientation is taken off
// (the heading is held, has_yaw false), sources = ranges, camera_mask 0; a constant-velocity
// filter that followed the body's camera poses too smooths the fixes and gives the velocity. Not thread-safe: owned
// by the fusion thread.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "ips/body/body_estimate.h"
#include "ips/fusion/kalman.h"

namespace ips {

/// Bodies are fused over the same time windows as markers (fusion.window, velocity_span, history).
struct BodyTrackOptions : FusionTimeWindows {
  /// A camera-placed pose's standard deviation per axis (m) over the number of cameras, as
  /// fusion.camera_sigma for markers: the covariance of the published pose (a mobile anchor's).
  double camera_sigma_m = 0.002;
  /// Where ranges alone place a body, a constant-velocity filter (fusion.out_of_view_process_noise,
  /// as for markers) that followed its camera poses too smooths the fixes, and its velocity is
  /// published.
  double between_cameras_process_noise = 0.1;

  bool operator==(const BodyTrackOptions&) const = default;
};

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

  /// A fix of a ranging tag on body `name` (unknown names are ignored) whose offset in the
  /// body's frame is `offset`, at fix.t_mono_ns with fix.covariance. Appends the body's pose
  /// from it when it may be published: see "Ranges" and "Order" (a fix older than the body's
  /// last published time is `late`; one within `camera_hold_s` of the body's newest camera
  /// frame is `held_for_cameras`).
  void add_fix(const std::string& name, const Eigen::Vector3d& offset, const WorldObservation& fix,
               double camera_hold_s, std::vector<FusedBody>& out);

  std::uint64_t late() const { return late_; }
  std::uint64_t held_for_cameras() const { return held_for_cameras_; }

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
    std::int64_t newest_ns = 0;                  // the newest camera frame's capture time
    bool published = false;
    FusedBody last;  // the last published pose
    struct Pose {
      std::int64_t t_ns = 0;
      Eigen::Vector3d position;
      bool has_yaw = false;
      double yaw = 0.0;
    };
    std::deque<Pose> path;  // recent published poses: the velocity span and one before it
    bool ranged = false;    // a tag's fix has come: between_cameras_ follows its camera poses too
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
  std::uint64_t held_for_cameras_ = 0;
  MarkerTracker between_cameras_;  // by body index (its "marker id")
  /// Appends the path point and the velocity of a pose about to be published.
  void publish(Track& track, FusedBody& f, std::vector<FusedBody>& out) const;
};

}  // namespace ips
