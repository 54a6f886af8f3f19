// World position on the floor from two tape distances to two known reference points (the
// published procedure's Eq. 25 helper): the intersection of two circles, one per side of
// the line between the references.
#include <cmath>
#include <cstdio>

#include "ips/collect/collect.h"
#include "ips/core/error.h"

namespace ips::collect {

std::array<Eigen::Vector2d, 2> from_two_distances(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double d_a,
                                                  double d_b, double slack) {
  const double ab = (b - a).norm();
  if (!(ab > 1e-6)) throw InputError("reference points A and B are the same point");
  if (!(d_a > 0 && d_b > 0)) throw InputError("tape distances must be > 0");
  char buf[200];
  if (d_a + d_b < ab - slack) {
    std::snprintf(buf, sizeof buf,
                  "%.3f + %.3f m is less than the %.3f m between A and B: the distances cannot "
                  "both be right",
                  d_a, d_b, ab);
    throw InputError(buf);
  }
  if (std::abs(d_a - d_b) > ab + slack) {
    std::snprintf(buf, sizeof buf,
                  "the distances differ by %.3f m, more than the %.3f m between A and B: they "
                  "cannot both be right",
                  std::abs(d_a - d_b), ab);
    throw InputError(buf);
  }
  // Along the line from a: s = (d_a^2 - d_b^2 + ab^2) / (2 ab); across it: h = sqrt(d_a^2 - s^2).
  const Eigen::Vector2d e = (b - a) / ab;
  const Eigen::Vector2d left(-e.y(), e.x());  // e turned +90 degrees
  const double s = (d_a * d_a - d_b * d_b + ab * ab) / (2 * ab);
  const double h = std::sqrt(std::max(0.0, d_a * d_a - s * s));  // 0 within the slack
  return {a + s * e + h * left, a + s * e - h * left};
}

}  // namespace ips::collect
