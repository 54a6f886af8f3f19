// cameras[].on_robot: one of ipsd's cameras rides on a robot and looks up at the ceiling's
// markers (docs/inside-out.md, "Live, in ipsd"). Its frames give the robot's pose through the
// ceiling map instead of markers through a fitted model; that pose enters fusion as one more
// source with a covariance, under the marker id the robot's records carry, so an overhead
// camera that sees the same marker and the robot's own camera make one track.
//
//   cameras:
//     - name: up
//       source: v4l2
//       device: /dev/video0
//       intrinsics: up.yaml
//       on_robot:
//         marker: 7              # required: the id of the robot's records
//         map: map.json          # required: the ceiling map (ips map), relative to ipsd.yaml
//         offset: [0, 0, 0.3]    # the lens in the robot's frame, m (default: at its origin)
//         yaw_deg: 0             # image +x from the robot's forward axis (as robot.yaml's mount)
//         roll_deg: 0
//         pitch_deg: 0
//         pixel_sigma: 0.5       # corner noise, px
//         outlier_px: 3.0        # a marker off by more (RMS) is left out
//         tilt_sigma_deg: 1.0    # how level the floor is
//         map_sigma: 0.01        # how well the map places its markers, m (added to the pose's)
#pragma once

#include <cstdint>
#include <filesystem>

#include "ips/core/observation.h"
#include "ips/insideout/localise.h"

namespace ips {

struct OnRobotSettings {
  int marker = -1;            ///< the id the robot's records carry (its marker, if it has one)
  std::filesystem::path map;  ///< the ceiling map (CeilingMap::load)
  CameraMount mount;
  LocaliseOptions localise;
  /// The map's own uncertainty per axis (1 sigma, m): localise()'s covariance assumes an exact
  /// map, which would let a pose from many markers outweigh every camera. The default is a
  /// conservative figure for a surveyed room (ips map's report gives the real one).
  double map_sigma_m = 0.01;

  bool operator==(const OnRobotSettings&) const = default;
};

/// The robot's pose of one localised frame as a world observation of `settings.marker`
/// (source kInsideOut, the stream of camera `camera_index`, with its heading and covariance:
/// the pose's x, y, z block plus map_sigma_m^2 per axis). `localisation.ok` must be true.
WorldObservation robot_observation(const Localisation& localisation, const OnRobotSettings& settings, int camera_index,
                                   std::int64_t t_mono_ns, std::int64_t t_real_ns);

}  // namespace ips
