// Lab frame -> the autopilot's local frame for the MAVLink output (docs/mavlink.md draws it).
// The lab frame is ENU-like: x forward as the lab defines it, y to its left, z up; yaw counter-
// clockwise from x. The autopilot's local frame is NED/FRD: x forward (north), y right (east),
// z down; heading clockwise from x. The lab's x axis points at heading `yaw_offset` in it.
#pragma once

#include <numbers>

#include "ips/output/packet_codec.h"

namespace ips {

/// The yaw variance (rad^2) sent for a record whose heading is held, not measured (ranges
/// alone, MarkerRecord::has_yaw false): pi^2, "anywhere within half a turn".
constexpr double kHeldYawVariance = std::numbers::pi * std::numbers::pi;

struct MavlinkPose {
  double n = 0, e = 0, d = 0;     ///< position in the local NED/FRD frame, metres
  double heading = 0;             ///< vehicle yaw in that frame, radians in (-pi, pi], clockwise from x
  double vn = 0, ve = 0, vd = 0;  ///< velocity in the local frame, m/s
  double cov[3][3] = {};          ///< position covariance in the local frame, m^2
};

/// `yaw_offset` = heading of the lab's x axis in the autopilot frame (radians, clockwise);
/// `marker_yaw` = the marker's x axis relative to the vehicle's nose (radians, counter-clockwise).
MavlinkPose lab_to_ned(const MarkerRecord& m, double yaw_offset, double marker_yaw);

}  // namespace ips
