// Marker corners -> camera coordinates by the marker-size depth formula.
#pragma once

#include <map>

#include "ips/camera_model.h"
#include "ips/observation.h"

namespace ips {

/// Marker edge lengths, metres: one default and per-ID exceptions.
struct MarkerSizes {
  double default_length = 0.20;
  std::map<int, double> by_id;
  double length_of(int id) const {
    auto it = by_id.find(id);
    return it == by_id.end() ? default_length : it->second;
  }
};

/// Undistorts the four corners, then zc = 4L / perimeter (normalised coordinates),
/// xc = zc * mean(u), yc = zc * mean(v); also yaw, pixel area and the corners.
CameraObservation locate_marker(const MarkerDetection& detection, const CameraModel& camera,
                                double edge_length);

}  // namespace ips
