// A robot's pose from the ceiling markers its own up-facing camera sees (inside-out
// localisation, docs/inside-out.md): all markers of one frame jointly, 6 degrees of freedom
// (an uneven floor tilts the camera), so the reported x, y, z and heading do not assume the
// camera is exactly vertical.
//
// Steps: each known marker's four corners give IPPE's two candidate poses (OpenCV,
// SOLVEPNP_IPPE_SQUARE on undistorted corners); the candidate that best explains every
// marker's corners wins (ties go to the one whose optical axis is nearer to the mount's);
// Levenberg-Marquardt then minimises the pixel reprojection error of all corners through the
// calibrated lens, with a prior that the robot stands upright on a level floor (tilt_sigma); a marker whose corners
// stay more than `outlier_px` (RMS) off is dropped (a marker moved since mapping, a wrong map entry) and the rest
// solved again. The covariance is sigma^2 (J^T J)^-1 with sigma the corner noise, carried to the robot's x, y, z, yaw.
#pragma once

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/core/observation.h"
#include "ips/geometry/camera_model.h"
#include "ips/insideout/ceiling_map.h"

namespace ips {

/// Where the camera sits on the robot. Robot frame: x forward, y left, z up; its origin is
/// the point whose pose is reported. The default: the lens at the origin, looking straight up,
/// image +x along the robot's forward axis (then image +y points to the robot's left).
struct CameraMount {
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< lens centre in the robot frame, m
  double yaw = 0.0;    ///< image +x axis from the robot's forward axis towards its left, rad
  double roll = 0.0;   ///< tilt of the optical axis about the robot's x axis, rad
  double pitch = 0.0;  ///< tilt about the robot's y axis, rad (applied after roll, before yaw)

  /// Columns: the camera's x, y, z (optical) axes in the robot frame.
  Eigen::Matrix3d camera_axes() const;

  bool operator==(const CameraMount&) const = default;
};

struct LocaliseOptions {
  double pixel_sigma = 0.5;  ///< corner noise, px (1 sigma): scales the covariance
  double outlier_px = 3.0;   ///< a marker whose corners are off by more than this (RMS) is dropped
  /// How far the robot may lean from upright (1 sigma, rad): a prior that the floor is level.
  /// It is what makes one marker alone useful (its own perspective barely separates a tilt
  /// from a shift); many markers outweigh it. 0 = none (tilt solved from the markers alone).
  double tilt_sigma = 0.017453292519943295;  // 1 degree
  int max_iterations = 30;                   ///< Levenberg-Marquardt iterations

  bool operator==(const LocaliseOptions&) const = default;
};

struct RobotPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();         ///< robot origin, world, m
  double yaw = 0.0;                                           ///< heading of the robot's x axis, world, rad
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();         ///< columns: robot x, y, z in the world (tilt included)
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();       ///< of x, y, z (m), yaw (rad)
  Eigen::Vector3d camera_position = Eigen::Vector3d::Zero();  ///< lens centre, world, m
  Eigen::Matrix3d camera_axes = Eigen::Matrix3d::Identity();  ///< columns: camera x, y, z in the world
};

struct Localisation {
  bool ok = false;
  RobotPose pose;             ///< valid when ok
  double rms_px = 0.0;        ///< RMS corner reprojection error of the markers used, px
  std::vector<int> used;      ///< ids that placed the robot
  std::vector<int> rejected;  ///< ids in the map whose corners disagreed with the others (outliers)
  std::vector<int> unknown;   ///< ids seen that the map does not have
  std::string why;            ///< when !ok: why not (no known marker, no consistent solution)
};

/// One of IPPE's two poses of a square marker in the camera (OpenCV's SOLVEPNP_IPPE_SQUARE on
/// the undistorted corners): the marker's axes (x right, y up as printed, z out of the printed
/// face) and its centre, in the camera frame.
struct MarkerInCamera {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};
/// Both candidates (none when a corner has no ray or the corners are degenerate).
std::vector<MarkerInCamera> marker_in_camera(const MarkerDetection& detection, double length,
                                             const CameraModel& camera);

/// The robot's pose from one frame's detections. Never throws on bad detections: a marker
/// that cannot be used is listed and left out.
Localisation localise(std::span<const MarkerDetection> detections, const CameraModel& camera, const CeilingMap& map,
                      const CameraMount& mount, const LocaliseOptions& options = {});

}  // namespace ips
