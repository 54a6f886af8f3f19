// Asynchronous, time-aligned fusion: every camera frame produces output at once, for the
// markers it saw, at that frame's capture time.
//
// Model of time. Each tracked object (today one marker id; later a rigid body fed the
// observations of several markers) keeps, per camera, a short time-ordered history of that
// camera's observations. When camera c's frame captured at T arrives, the object's state at T
// is the per-instant combination (mean/area/gauss/median, fusion.h) of one estimate per camera
// that saw it within `window_s` before T: camera c's own observation as is, every other
// camera's latest observation at or before T moved forward to T by that camera's own velocity
// (a least-squares line through its newest 3 frames within `velocity_span_s`; a camera without
// two frames there is left out unless its observation is from T itself). Per-camera
// velocities keep one camera's calibration bias out of another's motion.
//
// Order. Output for an object is produced only at a capture time >= the last time published
// for it, so its published capture times never decrease, whatever order frames arrive in. A
// frame that arrives late (its capture time is older than the object's last published time)
// is merged into the history, so later outputs use it, but produces no record for that object
// (counted as `late`). An observation older than `history_s` before the object's newest one is
// dropped (counted as `too_old`).
//
// Not thread-safe: owned by the fusion thread.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "ips/fusion/camera_lag.h"
#include "ips/fusion/fusion.h"
#include "ips/fusion/kalman.h"

namespace ips {

struct TrackFusionOptions : FusionTimeWindows {
  /// An object without a known height seen by one camera: publish the depth-formula position
  /// (true) or nothing (false). With >= 2 cameras' rays it is triangulated either way.
  bool single_camera_depth = false;
  /// A camera estimate's standard deviation (m) when it is weighed against a source that states
  /// its own covariance (ranges): the daemon's measured accuracy is mm-level, so a 5 cm range
  /// fix moves a camera-seen position by ~0.1 mm and fills in where no camera sees it. Where
  /// no camera sees an object, a constant-velocity filter smooths the other sources'
  /// estimates, started from the cameras' last state. Config: fusion.camera_sigma.
  double camera_sigma_m = 0.002;
  /// That filter's white-noise acceleration, m^2/s^3. 0.1 halves a 5 cm range fix's p95 for
  /// a robot at 0.2 m/s (tests/fusion/track_fusion_sources_test.cpp: 125 -> 75 mm); lower
  /// smooths more but claims more certainty than a turning robot allows at the hand-back.
  /// Config: fusion.out_of_view_process_noise.
  double between_cameras_process_noise = 0.1;
  /// While a camera has placed an object within this long (s) before another source's
  /// observation of it, that observation is merged (it weighs in the cameras' next records)
  /// but publishes no record of its own: a camera frame reaches fusion later than a range
  /// firing of the same instant (capture, decode, detection take tens of ms), so publishing
  /// the ranges first would leave every camera record "late" and unpublished. Where the
  /// cameras lose the object, the other sources take over this long after their last sight.
  /// Where camera frames reach fusion later than that (a busy machine; FrameObservations::
  /// t_fusion_ns), the hold is 1.5 times their largest lag over the last 5 s instead
  /// (effective_camera_hold_s). Config: fusion.camera_hold.
  double camera_hold_s = 0.5;
  bool kalman = false;  ///< constant-velocity Kalman filter per object on the output
  KalmanOptions kalman_options;

  bool operator==(const TrackFusionOptions&) const = default;
};

struct TrackFusionCounters {
  std::uint64_t late = 0;     ///< observations merged but not published (older than the last output)
  std::uint64_t too_old = 0;  ///< observations dropped: older than the history span
  /// Other sources' observations merged without a record of their own: a camera had the
  /// object within camera_hold_s.
  std::uint64_t held_for_cameras = 0;
};

class TrackFusion {
 public:
  explicit TrackFusion(const TrackFusionOptions& options = {});

  /// Feeds one camera frame's observations (all at batch.t_mono_ns) and appends to `out` the
  /// fused state at that capture time of every object the frame saw and that may be published
  /// (see "Order"), sorted by id. FusedMarker::t_mono_ns is the capture time of the frame.
  /// `out` == nullptr only feeds the histories (fixed-rate output publishes by predict_all).
  void add(const FrameObservations& batch, const FusionMethod& method, std::vector<FusedMarker>* out);

  /// Takes over `previous`'s histories and last published times (a reload that changed the
  /// options keeps the order guarantee; the Kalman filters restart).
  void continue_after(const TrackFusion& previous) {
    tracks_ = previous.tracks_;
    latest_ns_ = previous.latest_ns_;
    latest_camera_ns_ = previous.latest_camera_ns_;
    camera_lag_ = previous.camera_lag_;
  }

  /// Fused state of every object seen within history_s before `t_mono_ns`, predicted to that
  /// time (fixed-rate output; the wider window covers the capture latency), sorted by id. Objects whose last published
  /// time is later are left out; the published time of the others becomes t_mono_ns. `t_real_ns` is stamped.
  void predict_all(std::int64_t t_mono_ns, std::int64_t t_real_ns, const FusionMethod& method,
                   std::vector<FusedMarker>& out);

  const TrackFusionCounters& counters() const { return counters_; }
  /// camera_hold_s, or longer where the cameras' frames reach fusion later than it.
  double effective_camera_hold_s() const;
  std::size_t tracks() const { return tracks_.size(); }
  const TrackFusionOptions& options() const { return options_; }

 private:
  struct Track {
    /// Time-ordered per stream: a camera, or one stream of another source (stream_key()).
    std::map<int, std::deque<WorldObservation>> by_camera;
    std::int64_t newest_ns = 0;
    std::int64_t published_ns = 0;
    bool published = false;
    /// Recent published (time, position): the object's velocity for moving rays, which carry
    /// no position of their own to fit.
    std::deque<std::pair<std::int64_t, Eigen::Vector3d>> path;
    double yaw = 0.0;  ///< last published heading, held while only headingless sources see the object
    /// A source other than the cameras has seen the object: only then does between_cameras_
    /// follow its camera records (a camera-only object never needs the hand-over).
    bool other_sources = false;
    std::int64_t camera_newest_ns = INT64_MIN;  ///< the newest camera observation's capture time
  };
  /// The estimates of every stream at time t, each moved to t by its own velocity; the
  /// streams' velocities are summed and counted, the cameras' apart from the other sources'.
  std::vector<WorldObservation> estimates_at(const Track& track, std::int64_t t, std::int64_t t_real,
                                             std::int64_t window_ns, Eigen::Vector3d& camera_v, int& camera_v_count,
                                             Eigen::Vector3d& other_v, int& other_v_count) const;
  /// The cameras' estimates fused as before sources were added (method, rays, depth formula).
  std::optional<FusedMarker> camera_state(int id, const Track& track, std::vector<WorldObservation> estimates,
                                          std::int64_t t, std::int64_t t_real, const FusionMethod& method,
                                          const std::optional<Eigen::Vector3d>& velocity) const;
  Eigen::Vector3d path_velocity(const Track& track) const;
  /// Combines the cameras' estimates of `track` at time t (nullopt if none is recent enough).
  std::optional<FusedMarker> state_at(int id, const Track& track, std::int64_t t_mono_ns, std::int64_t t_real_ns,
                                      std::int64_t window_ns, const FusionMethod& method) const;
  void finish(FusedMarker& f, Track& track);
  static std::int64_t newest_of_kind(const Track& track, ObservationSource source);
  void prune(Track& track) const;

  TrackFusionOptions options_;
  std::map<int, Track> tracks_;
  std::int64_t latest_ns_ = 0;         ///< newest capture time fed
  std::int64_t latest_camera_ns_ = 0;  ///< newest capture time of a camera frame fed (cameras lag the others)
  CameraLag camera_lag_;
  std::optional<MarkerTracker> kalman_;
  /// Follows every object on every record (cameras at camera_sigma_m, other sources at their
  /// covariance); where no camera sees it, what is published is this filter's state: noisy
  /// range fixes are smoothed, and the hand-over starts from the cameras' position and velocity.
  MarkerTracker between_cameras_;
  TrackFusionCounters counters_;
};

}  // namespace ips
