// Fusion: what several cameras saw of the same marker within one time window -> one pose.
// Methods are chosen by name from a registry; an unknown name is a start-up error.
#pragma once

#include <cstdint>
#include <set>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/core/observation.h"
#include "ips/mapping/mapper.h"

namespace ips {

/// The time windows of asynchronous fusion, shared by markers (TrackFusion) and bodies
/// (BodyTrack): fusion.window, fusion.velocity_span and fusion.history of the configuration.
struct FusionTimeWindows {
  /// Another camera's observation is used (motion-compensated) when it is at most this much
  /// older than the output time, s. A camera at 30 fps needs >= 1/30 s plus jitter.
  double window_s = 0.050;
  /// Velocities come from observations (a camera's own, or a body's published positions)
  /// within this span, s. With fewer than 2 there, an estimate is used only at its own instant.
  double velocity_span_s = 0.200;
  /// How far back the per-camera histories reach (the reorder buffer), s; observations older
  /// than this before the object's newest one are dropped and counted.
  double history_s = 0.250;

  bool operator==(const FusionTimeWindows&) const = default;
};

/// One marker's fused pose. Units SI.
struct FusedMarker {
  int id = -1;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  ///< metres
  double yaw = 0.0;                                   ///< world heading, radians in (-pi, pi]
  std::uint32_t camera_mask = 0;                      ///< bit i = camera index i contributed
  std::uint16_t sources = 0;                          ///< source_bit() of every source that contributed
  /// False when no contribution had a heading (ranges alone): `yaw` is then the last published
  /// heading held, or 0.
  bool has_yaw = true;
  double quality = 0.0;        ///< sum of contributing pixel areas, px^2
  double spread = 0.0;         ///< max distance of a contributing estimate from p_world, m
  std::int64_t t_mono_ns = 0;  ///< weighted mean capture time of the contributions
  std::int64_t t_real_ns = 0;
  bool has_velocity = false;                           ///< velocity is an estimate (Kalman, or the cameras' own motion)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s
  /// Position covariance, m^2: the Kalman filter's when it runs; otherwise the scatter of the
  /// cameras' estimates plus one measurement variance, both divided by the number of cameras.
  /// Not on the v1 wire; kept for outputs that carry it (ROS, MAVLink).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

/// Relative weight of each observation (all of one marker id); the registry's methods.
/// `median` has no weights: it is handled by fuse_marker itself.
struct FusionMethod {
  std::string name;
  std::string description;
  double (*weight)(const WorldObservation&);  ///< nullptr for the median
};

/// The registry, in documentation order: mean, area, gauss, median.
const std::vector<FusionMethod>& fusion_methods();
/// Looks a method up by name; throws ips::InputError naming `where` and listing the known ones.
const FusionMethod& find_fusion_method(const std::string& name, const std::string& where);

/// Fuses observations of ONE marker id (non-empty). Position: weighted mean (per-axis median
/// for `median`); yaw: weighted circular mean (unweighted for `median`) of those that have one;
/// time: weighted mean. Only camera observations set bits of camera_mask.
FusedMarker fuse_marker(std::span<const WorldObservation> observations, const FusionMethod& method);

/// Groups `observations` by marker id and fuses each group; result sorted by id.
/// A camera seeing the same id twice in one window (an impostor / a reflection) contributes
/// each sighting.
std::vector<FusedMarker> fuse(std::span<const WorldObservation> observations, const FusionMethod& method);

/// The observations of one processed frame of one camera.
struct FrameObservations {
  int camera_index = -1;
  std::int64_t t_mono_ns = 0;  ///< capture time of the frame
  std::int64_t t_real_ns = 0;
  std::int64_t t_delivered_ns = 0;  ///< when the source delivered the frame, CLOCK_MONOTONIC
  std::int64_t t_fusion_ns = 0;     ///< when fusion took it, CLOCK_MONOTONIC; 0 = not known
  std::vector<WorldObservation> observations;
};

}  // namespace ips
