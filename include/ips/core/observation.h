// Plain structs passed between the pipeline stages (see ARCHITECTURE.md).
// Units: metres, radians, seconds/nanoseconds. Image coordinates in pixels,
// origin at the centre of the top-left pixel, x right, y down.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Core>

namespace ips {

/// A 2-D point in pixels or normalised image coordinates.
struct Point2 {
  double x = 0.0;
  double y = 0.0;
};

/// One ArUco marker found in one image.
/// Corner order is OpenCV ArUco's: the marker's top-left, top-right, bottom-right,
/// bottom-left as printed, i.e. clockwise in the image when seen from the front.
struct MarkerDetection {
  int id = -1;
  std::array<Point2, 4> corners_px{};
};

/// A marker in one camera's coordinate frame, from the marker-size depth formula.
struct CameraObservation {
  int id = -1;
  Eigen::Vector3d p_cam = Eigen::Vector3d::Zero();  ///< (xc, yc, zc), metres
  double yaw = 0.0;                                 ///< marker x-axis heading in the camera x-y plane, radians
  double area_px = 0.0;                             ///< marker area in the image, px^2 (shoelace formula)
  double edge_length = 0.0;                         ///< marker edge length L used for the depth, metres
  std::array<Point2, 4> corners_px{};               ///< raw corners, pixels
  std::array<Point2, 4> corners_norm{};             ///< undistorted corners, normalised (u, v)
};

/// Where a world observation came from. Fusion combines the cameras' estimates of one
/// instant by the configured method, then what other sources say by their covariances.
enum class ObservationSource : std::uint8_t {
  kCamera = 0,  ///< a ceiling camera's marker detection
  kRanges = 1,  ///< a fix solved from one firing's ranges (UWB / ultrasound)
  /// the robot's pose from its own up-facing camera reading the ceiling map (docs/inside-out.md)
  kInsideOut = 2,
};

/// Bit of a source in FusedMarker::sources.
constexpr std::uint16_t source_bit(ObservationSource s) {
  return static_cast<std::uint16_t>(1u << static_cast<unsigned>(s));
}

/// A marker in world coordinates as seen by one camera (or solved by another source).
struct WorldObservation {
  int id = -1;
  /// Index of the camera in the daemon's configuration; for another source, the index of the
  /// stream within it (a ranging tag's id): estimates of one stream are fitted for velocity together.
  int camera_index = -1;
  ObservationSource source = ObservationSource::kCamera;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  ///< metres
  double yaw = 0.0;                                   ///< heading in the world x-y plane, radians
  double area_px = 0.0;                               ///< pixel area, for fusion weights
  std::int64_t t_mono_ns = 0;                         ///< capture time, CLOCK_MONOTONIC
  std::int64_t t_real_ns = 0;                         ///< capture time, CLOCK_REALTIME
  /// False when the marker's height is unknown: p_world is then the depth-formula point on the
  /// camera ray (cm-level in z), and the ray below lets fusion triangulate with other cameras.
  bool height_known = true;
  bool has_yaw = true;  ///< false: a source that gives no heading (ranges); `yaw` is then ignored
  /// A source other than a camera states its uncertainty (m^2); camera estimates are weighed
  /// by the fusion method and TrackFusionOptions::camera_sigma_m instead.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  bool has_ray = false;
  Eigen::Vector3d ray_origin = Eigen::Vector3d::Zero();     ///< camera centre, world, metres
  Eigen::Vector3d ray_direction = Eigen::Vector3d::Zero();  ///< unit vector towards the marker
};

}  // namespace ips
