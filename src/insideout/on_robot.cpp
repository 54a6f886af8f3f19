#include "ips/insideout/on_robot.h"

namespace ips {

WorldObservation robot_observation(const Localisation& localisation, const OnRobotSettings& settings, int camera_index,
                                   std::int64_t t_mono_ns, std::int64_t t_real_ns) {
  WorldObservation w;
  w.id = settings.marker;
  w.camera_index = camera_index;  // the stream: one riding camera's poses are fitted for velocity together
  w.source = ObservationSource::kInsideOut;
  w.p_world = localisation.pose.position;
  w.yaw = localisation.pose.yaw;
  w.has_yaw = true;
  w.t_mono_ns = t_mono_ns;
  w.t_real_ns = t_real_ns;
  w.covariance = localisation.pose.covariance.topLeftCorner<3, 3>() +
                 settings.map_sigma_m * settings.map_sigma_m * Eigen::Matrix3d::Identity();
  return w;
}

}  // namespace ips
