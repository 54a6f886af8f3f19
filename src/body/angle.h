// Angles in the body stage (private to src/body).
#pragma once

#include <cmath>

namespace ips::body_detail {

/// `a` wrapped into (-pi, pi].
inline double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

}  // namespace ips::body_detail
