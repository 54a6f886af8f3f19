// A camera's footprint on the floor, from its pose model (the plane mapper's world ray), for
// the map. Cameras whose mapper has no pose (rt, pr, ann, ...) have none.
#include <cmath>

#include "ips/geometry/camera_model.h"
#include "ips/mapping/mapper.h"
#include "ips/web/web.h"

namespace ips {

std::vector<Eigen::Vector2d> camera_footprint(const CameraModel& intrinsics, const Mapper& mapper, double height,
                                              double max_range) {
  std::vector<Eigen::Vector2d> polygon;
  const cv::Size size = intrinsics.size();
  if (size.width <= 0 || size.height <= 0) return polygon;
  // The image border, clockwise, 16 samples per side (fisheye edges are curved on the floor).
  constexpr int kPerSide = 16;
  std::vector<Point2> border;
  const double w = size.width - 1, h = size.height - 1;
  for (int i = 0; i < kPerSide; ++i) border.push_back({w * i / kPerSide, 0});
  for (int i = 0; i < kPerSide; ++i) border.push_back({w, h * i / kPerSide});
  for (int i = 0; i < kPerSide; ++i) border.push_back({w - w * i / kPerSide, h});
  for (int i = 0; i < kPerSide; ++i) border.push_back({0, h - h * i / kPerSide});
  for (const Point2& px : border) {
    const Point2 n = intrinsics.undistort(px);
    if (!std::isfinite(n.x) || !std::isfinite(n.y)) continue;  // beyond the model's field of view
    const Eigen::Vector3d cam = Eigen::Vector3d(n.x, n.y, 1.0).normalized();
    Eigen::Vector3d origin, dir;
    if (!mapper.world_ray(cam, origin, dir)) return {};
    const Eigen::Vector2d below(origin.x(), origin.y());
    Eigen::Vector2d horizontal(dir.x(), dir.y());
    if (horizontal.norm() < 1e-12) horizontal = Eigen::Vector2d(1, 0);
    Eigen::Vector2d p = below + max_range * horizontal.normalized();  // ray misses the floor: cut at max_range
    if (dir.z() < -1e-9) {
      const double t = (height - origin.z()) / dir.z();
      const Eigen::Vector3d hit = origin + t * dir;
      const Eigen::Vector2d q(hit.x(), hit.y());
      if (t > 0 && (q - below).norm() < max_range) p = q;
    }
    polygon.push_back(p);
  }
  return polygon;
}

}  // namespace ips
