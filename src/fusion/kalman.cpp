#include "ips/fusion/kalman.h"

#include <algorithm>

#include <Eigen/Dense>

namespace ips {

void MarkerTracker::start(Track& t, const FusedMarker& m, const Eigen::Vector3d& variance) const {
  t.t_ns = m.t_mono_ns;
  for (int k = 0; k < 3; ++k) {
    t.axis[k].x = {m.p_world[k], 0.0};
    t.axis[k].P =
        Eigen::Vector2d(variance[k], options_.initial_velocity_std * options_.initial_velocity_std).asDiagonal();
  }
}

void MarkerTracker::update(FusedMarker& m, const Eigen::Vector3d& variance) {
  auto [it, fresh] = tracks_.try_emplace(m.id);
  Track& t = it->second;
  const double dt = 1e-9 * static_cast<double>(m.t_mono_ns - t.t_ns);
  if (fresh || dt > options_.reset_after_s) {
    start(t, m, variance);
  } else {
    // An out-of-order measurement (dt < 0) is applied at the track's time (no prediction).
    const double h = dt > 0.0 ? dt : 0.0;
    Eigen::Matrix2d F;
    F << 1.0, h, 0.0, 1.0;
    const double q = options_.process_noise;
    Eigen::Matrix2d Q;
    Q << q * h * h * h / 3.0, q * h * h / 2.0, q * h * h / 2.0, q * h;
    for (int k = 0; k < 3; ++k) {
      Axis& a = t.axis[k];
      a.x = F * a.x;
      a.P = F * a.P * F.transpose() + Q;
      // Measurement of the position only: H = [1 0].
      const double s = a.P(0, 0) + variance[k];
      const Eigen::Vector2d K = a.P.col(0) / s;
      const double innovation = m.p_world[k] - a.x[0];
      a.x += K * innovation;
      const Eigen::Matrix2d I_KH = Eigen::Matrix2d::Identity() - K * Eigen::RowVector2d(1.0, 0.0);
      a.P = I_KH * a.P;
    }
    if (dt > 0.0) t.t_ns = m.t_mono_ns;
  }
  m.covariance.setZero();  // independent axes
  for (int k = 0; k < 3; ++k) {
    m.p_world[k] = t.axis[k].x[0];
    m.velocity[k] = t.axis[k].x[1];
    m.covariance(k, k) = t.axis[k].P(0, 0);
  }
  m.has_velocity = true;
}

KalmanOptions between_cameras_options(KalmanOptions base, double process_noise) {
  base.process_noise = process_noise;
  base.reset_after_s = std::max(1.0, base.reset_after_s);
  return base;
}

}  // namespace ips
