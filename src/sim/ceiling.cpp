#include "ips/sim/ceiling.h"

namespace ips::sim {

CeilingMap ceiling_map(const Scene& scene) {
  CeilingMap map;
  map.dictionary = scene.dictionary;
  for (std::size_t i = 0; i < scene.markers.size(); ++i) {
    const SceneMarker& m = scene.markers[i];
    const MarkerPose p = scene.marker_pose_at(i, 0.0);
    // Face down and fixed: a marker on a body or facing anywhere else is not the ceiling's.
    if (m.body >= 0 || m.trajectory.kind != Trajectory::Kind::kStatic || !p.tilted || !(p.axes(2, 2) < -0.999)) {
      continue;
    }
    CeilingMarker c;
    c.id = m.id;
    c.centre = {p.x, p.y, p.z};
    c.yaw = p.yaw;
    c.length = m.length;
    map.markers.push_back(c);
  }
  return map;
}

}  // namespace ips::sim
