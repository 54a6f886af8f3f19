// Marker corners -> camera coordinates by the marker-size depth formula.
#pragma once

#include <map>

#include "ips/core/observation.h"
#include "ips/geometry/camera_model.h"

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
/// yaw = atan2 of the marker x-axis (mid-left edge -> mid-right edge, i.e. corners
/// 0,3 -> 1,2) in normalised coordinates: the heading in the camera's x-y plane.
CameraObservation locate_marker(const MarkerDetection& detection, const CameraModel& camera, double edge_length);

/// The same formula on an observation whose corners_norm, corners_px and edge_length are
/// already set (the simulator's exact ground truth uses this on exactly projected corners).
CameraObservation locate_from_normalised(CameraObservation obs);

/// Area of the quadrilateral, px^2 (shoelace formula; either winding).
double polygon_area_px(const std::array<Point2, 4>& corners);

}  // namespace ips
