// Optional per-marker smoothing and velocity: a constant-velocity Kalman filter per world axis.
#pragma once

#include <cstdint>
#include <map>

#include <Eigen/Core>

#include "ips/fusion/fusion.h"

namespace ips {

struct KalmanOptions {
  /// Spectral density of the white-noise acceleration driving the model, m^2/s^3. Larger =
  /// follows manoeuvres faster, smooths less. Default 0.5 suits lab robots (~1 m/s^2 turns).
  double process_noise = 0.5;
  /// Variance of one fused position measurement, m^2. Default 1e-4 (1 cm standard deviation).
  double measurement_noise = 1e-4;
  /// A marker unseen for longer than this restarts its track (position = measurement,
  /// velocity 0), seconds. Default 0.5.
  double reset_after_s = 0.5;
  /// Standard deviation of the velocity of a new track, m/s. Default 1.
  double initial_velocity_std = 1.0;

  bool operator==(const KalmanOptions&) const = default;
};

/// The filter that carries a track between the cameras' views (fixes from ranges alone):
/// `base` with `process_noise` (fusion.out_of_view_process_noise), and kept through gaps of up
/// to 1 s at least (a fix every 150 ms at the least).
KalmanOptions between_cameras_options(KalmanOptions base, double process_noise);

/// Keeps one filter per marker id. Not thread-safe: owned by the fusion thread.
class MarkerTracker {
 public:
  explicit MarkerTracker(const KalmanOptions& options = {}) : options_(options) {}

  /// Filters `m` in place at its capture time m.t_mono_ns: replaces p_world by the filtered
  /// position and sets velocity / has_velocity.
  void update(FusedMarker& m) { update(m, Eigen::Vector3d::Constant(options_.measurement_noise)); }
  /// The same with this measurement's variance per axis, m^2 (a source that states its own).
  void update(FusedMarker& m, const Eigen::Vector3d& measurement_variance);

  std::size_t tracks() const { return tracks_.size(); }

 private:
  struct Axis {
    Eigen::Vector2d x = Eigen::Vector2d::Zero();  // position, velocity
    Eigen::Matrix2d P = Eigen::Matrix2d::Identity();
  };
  struct Track {
    std::int64_t t_ns = 0;
    Axis axis[3];
  };
  void start(Track& t, const FusedMarker& m, const Eigen::Vector3d& variance) const;

  KalmanOptions options_;
  std::map<int, Track> tracks_;
};

}  // namespace ips
