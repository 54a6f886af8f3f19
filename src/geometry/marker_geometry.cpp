// The marker-size depth formula of the published system (see marker_geometry.h).
#include "ips/geometry/marker_geometry.h"

#include <cmath>

namespace ips {

double polygon_area_px(const std::array<Point2, 4>& c) {
  double twice = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    const Point2& a = c[i];
    const Point2& b = c[(i + 1) % 4];
    twice += a.x * b.y - b.x * a.y;
  }
  return std::abs(twice) / 2.0;
}

CameraObservation locate_marker(const MarkerDetection& detection, const CameraModel& camera, double edge_length) {
  CameraObservation obs;
  obs.id = detection.id;
  obs.edge_length = edge_length;
  obs.corners_px = detection.corners_px;
  camera.undistort(detection.corners_px, obs.corners_norm);
  return locate_from_normalised(obs);
}

CameraObservation locate_from_normalised(CameraObservation obs) {
  const auto& n = obs.corners_norm;
  double perimeter = 0.0;
  double su = 0.0;
  double sv = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    const Point2& a = n[i];
    const Point2& b = n[(i + 1) % 4];
    perimeter += std::hypot(b.x - a.x, b.y - a.y);
    su += a.x;
    sv += a.y;
  }
  const double zc = 4.0 * obs.edge_length / perimeter;
  obs.p_cam = {zc * su / 4.0, zc * sv / 4.0, zc};
  // Marker x-axis: from the left edge (corners 0 = top-left, 3 = bottom-left) to the right
  // edge (1 = top-right, 2 = bottom-right), averaged over both edges.
  const double dx = (n[1].x + n[2].x) - (n[0].x + n[3].x);
  const double dy = (n[1].y + n[2].y) - (n[0].y + n[3].y);
  obs.yaw = std::atan2(dy, dx);
  obs.area_px = polygon_area_px(obs.corners_px);
  return obs;
}

}  // namespace ips
