// Cross-check of the configuration against the loaded model file (kept apart from the parser
// so that parsing does not depend on the mapping stage).
#include <cmath>

#include "ips/config/config.h"
#include "ips/core/error.h"
#include "ips/mapping/mapper.h"
#include "ips/mapping/model_file.h"

namespace ips {

void check_models(const DaemonConfig& config, const ModelSet& models) {
  const std::string file = config.file.string();
  bool any_height = !std::isnan(config.markers.height);
  for (const auto& [id, info] : config.markers.ids) any_height = any_height || !std::isnan(info.height);
  // Without heights, mappers with a camera pose triangulate where >= 2 cameras overlap.
  int ray_cameras = 0;
  for (const auto& cam : config.cameras) {
    if (config.on_robot.contains(cam.index)) continue;  // maps through the ceiling map
    Eigen::Vector3d o, d;
    const Mapper* mapper = models.find(cam.model);
    if (mapper && mapper->world_ray(Eigen::Vector3d(0, 0, 1), o, d)) ++ray_cameras;
  }
  const bool rays_suffice = ray_cameras >= 2 || (ray_cameras == 1 && config.fusion.single_camera_depth);
  for (const auto& cam : config.cameras) {
    if (config.on_robot.contains(cam.index)) continue;
    const std::string key = file + ": cameras[" + std::to_string(cam.index) + "].model";
    const Mapper* mapper = models.find(cam.model);
    if (!mapper) {
      std::string known;
      for (const auto& [name, entry] : models.cameras) known += (known.empty() ? "" : ", ") + name;
      throw InputError(key + ": model file " + config.model_file.string() + " has no camera '" + cam.model +
                       "' (it has: " + (known.empty() ? "none" : known) + ")");
    }
    Eigen::Vector3d o, d;
    const bool has_rays = mapper->world_ray(Eigen::Vector3d(0, 0, 1), o, d);
    if (mapper->needs_height() && !any_height && !(has_rays && rays_suffice))
      throw InputError(file + ": markers.height: camera '" + cam.name + "' uses the '" + mapper->method() +
                       "' mapper, which needs a known marker height (or a second camera with a pose model to "
                       "triangulate, or fusion.single_camera_depth); set markers.height or markers.ids.<id>.height");
  }
}

}  // namespace ips
