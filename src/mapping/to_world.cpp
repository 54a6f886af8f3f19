#include "ips/mapping/to_world.h"

#include <cmath>

namespace ips {

WorldObservation to_world(const CameraObservation& obs, const Mapper& mapper, double known_height, int camera_index,
                          std::int64_t t_mono_ns, std::int64_t t_real_ns, double heading_step) {
  WorldObservation w;
  w.id = obs.id;
  w.camera_index = camera_index;
  w.area_px = obs.area_px;
  w.t_mono_ns = t_mono_ns;
  w.t_real_ns = t_real_ns;
  w.p_world = mapper.predict(obs.p_cam, known_height);
  const Eigen::Vector3d ahead = obs.p_cam + heading_step * Eigen::Vector3d(std::cos(obs.yaw), std::sin(obs.yaw), 0.0);
  const Eigen::Vector3d w_ahead = mapper.predict(ahead, known_height);
  w.yaw = std::atan2(w_ahead.y() - w.p_world.y(), w_ahead.x() - w.p_world.x());
  return w;
}

MappedMarker map_marker(const CameraObservation& obs, const Mapper& mapper, double known_height, int camera_index,
                        std::int64_t t_mono_ns, std::int64_t t_real_ns, WorldObservation& out) {
  double height = known_height;
  Eigen::Vector3d ray_origin, ray_direction;
  const bool ray_only =
      mapper.needs_height() && std::isnan(height) && mapper.world_ray(obs.p_cam, ray_origin, ray_direction);
  // Height unknown: the depth-formula point on the ray stands in (z from the marker size).
  if (ray_only) height = (ray_origin + obs.p_cam.norm() * ray_direction).z();
  if (mapper.needs_height() && std::isnan(height)) return MappedMarker::kNoHeight;
  out = to_world(obs, mapper, height, camera_index, t_mono_ns, t_real_ns);
  if (!out.p_world.allFinite() || !std::isfinite(out.yaw)) return MappedMarker::kDegenerate;
  if (ray_only) {
    out.height_known = false;
    out.has_ray = true;
    out.ray_origin = ray_origin;
    out.ray_direction = ray_direction;
  }
  return MappedMarker::kMapped;
}

}  // namespace ips
