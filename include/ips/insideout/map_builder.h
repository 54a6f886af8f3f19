// `ips map`: the ceiling's markers mapped from a drive of the robot's up-facing camera
// (docs/inside-out.md). Every marker lies face down on the ceiling (x, y, z, yaw); every frame
// has its own 6-DoF camera pose, so an uneven floor does not bend the map; the scale is the
// markers' known edge length; references put the map in the lab's world frame.
//
// Steps: (1) chain: the first frame's camera defines a provisional frame; each frame is
// localised against the markers mapped so far (localise.h) and places the markers it sees for
// the first time (IPPE, turned face down), in passes until no frame adds one; (2) bundle
// adjustment with Ceres: every corner's ray against the modelled corner (a tangent-plane error
// times the focal length, about pixels), a Huber loss, the first marker held (the 4 degrees
// of freedom a face-down ceiling leaves: x, y, z and a turn about the vertical); (3) the map
// turned and shifted onto the references (>= 2 centres, or one with its yaw), their residuals
// reported. Each marker's sigma (x, y, z, yaw) is the adjustment's covariance relative to the
// held marker, scaled by the corner noise the residuals show.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/core/observation.h"
#include "ips/geometry/camera_model.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/insideout/ceiling_map.h"

namespace ips {

/// One frame of the drive: its detections.
struct DriveFrame {
  std::int64_t t_ns = 0;
  std::vector<MarkerDetection> markers;
};

/// A marker whose place in the lab is known (refs.yaml): its centre, and optionally the heading
/// of its printed x axis seen from below.
struct MapReference {
  int id = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::optional<double> yaw;
};

struct MapBuildOptions {
  std::string dictionary = "DICT_4X4_100";
  MarkerSizes sizes;      ///< the markers' edge lengths: the map's scale
  double huber_px = 1.0;  ///< corners further off than this weigh less (robust loss)
  int max_iterations = 100;
};

struct ReferenceResidual {
  int id = -1;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< mapped centre - given centre, m
  double yaw_offset = 0.0;                           ///< mapped - given heading, rad (0 if not given)
};

struct MapBuildResult {
  CeilingMap map;  ///< in the references' frame
  std::vector<ReferenceResidual> references;
  int frames = 0;                ///< frames given
  int frames_used = 0;           ///< frames that placed the camera
  int corners = 0;               ///< corner observations in the adjustment
  double rms_px = 0.0;           ///< their RMS error after it
  std::vector<int> unconnected;  ///< ids seen only in frames that share no marker with the map
  /// The marker held in the adjustment (the smallest id): every marker's `sigma` in the map is
  /// its uncertainty relative to this one (whose own is 0); the references' residuals say how
  /// well the whole map sits in the lab.
  int anchor = -1;
  struct Pose {
    std::int64_t t_ns;
    Eigen::Vector3d position;  ///< lens centre
    double yaw;                ///< heading of image +x
  };
  std::vector<Pose> cameras;  ///< the drive, frame by frame (for the report)
};

/// Builds the map. Throws ips::InputError when the references cannot place it: fewer than two
/// centres and no reference with a yaw, a reference id no frame saw, or no frame with a marker.
MapBuildResult build_ceiling_map(const std::vector<DriveFrame>& frames, const CameraModel& camera,
                                 const std::vector<MapReference>& references, const MapBuildOptions& options);

}  // namespace ips
