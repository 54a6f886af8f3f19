#include "ips/output/mavlink_pose.h"

#include <cmath>
#include <numbers>

namespace ips {

namespace {

double wrap_pi(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);  // [-pi, pi]
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

}  // namespace

MavlinkPose lab_to_ned(const MarkerRecord& m, double yaw_offset, double marker_yaw) {
  // Lab x at heading yaw_offset (clockwise from north/forward), lab y 90 degrees to its left,
  // lab z up. Columns of R = the lab axes in (north, east, down).
  const double c = std::cos(yaw_offset), s = std::sin(yaw_offset);
  const double R[3][3] = {{c, s, 0}, {s, -c, 0}, {0, 0, -1}};
  MavlinkPose p;
  p.n = R[0][0] * m.x + R[0][1] * m.y;
  p.e = R[1][0] * m.x + R[1][1] * m.y;
  p.d = -m.z;
  p.vn = R[0][0] * m.vx + R[0][1] * m.vy;
  p.ve = R[1][0] * m.vx + R[1][1] * m.vy;
  p.vd = -m.vz;
  // Lab yaw is counter-clockwise from lab x; the autopilot's heading is clockwise from its x.
  p.heading = wrap_pi(yaw_offset - (m.yaw - marker_yaw));
  const double C[3][3] = {{m.covariance[0], m.covariance[1], m.covariance[2]},
                          {m.covariance[1], m.covariance[3], m.covariance[4]},
                          {m.covariance[2], m.covariance[4], m.covariance[5]}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double v = 0;
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) v += R[i][k] * C[k][l] * R[j][l];
      p.cov[i][j] = v;
    }
  return p;
}

}  // namespace ips
