// A marker seen by one camera -> the world, through that camera's fitted mapper.
#pragma once

#include <cstdint>

#include "ips/core/observation.h"
#include "ips/mapping/mapper.h"

namespace ips {

/// Camera observation -> world observation through that camera's mapper. The world heading
/// maps a second point, `heading_step` metres along the marker's x-axis in the camera frame
/// (direction (cos yaw, sin yaw, 0)), through the same mapper and takes atan2 of the world
/// difference: correct for every mapper, including non-rigid ones.
WorldObservation to_world(const CameraObservation& obs, const Mapper& mapper, double known_height, int camera_index,
                          std::int64_t t_mono_ns, std::int64_t t_real_ns, double heading_step = 0.05);

enum class MappedMarker {
  kMapped,      ///< `out` holds the world observation
  kNoHeight,    ///< the mapper needs the marker's height, none is known and it gives no ray
  kDegenerate,  ///< the mapper gave a non-finite position or heading (degenerate corners)
};

/// One marker of one frame into the world, as the daemon does it. `known_height` is the
/// marker's world z (NaN = unknown). A mapper that needs a height but knows its camera's pose
/// (plane) still places a marker of unknown height: the depth-formula point on the marker's ray
/// stands in, and `out` carries the ray (has_ray, height_known = false) for fusion to
/// triangulate with other cameras' rays.
MappedMarker map_marker(const CameraObservation& obs, const Mapper& mapper, double known_height, int camera_index,
                        std::int64_t t_mono_ns, std::int64_t t_real_ns, WorldObservation& out);

}  // namespace ips
