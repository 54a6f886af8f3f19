// Was the marker seen steadily by one camera over the frames of a placement?
#include <cmath>

#include "ips/collect/collect.h"

namespace ips::collect {

CameraVerdict judge(const std::vector<Eigen::Vector3d>& samples, int frames, const SteadyOptions& options) {
  CameraVerdict v;
  v.frames = frames;
  v.seen = static_cast<int>(samples.size());
  if (samples.empty()) return v;  // kNotSeen
  for (const auto& p : samples) v.mean += p;
  v.mean /= static_cast<double>(samples.size());
  for (const auto& p : samples) v.spread = std::max(v.spread, (p - v.mean).norm());
  if (v.seen < std::ceil(options.min_seen_fraction * frames - 1e-9)) {
    v.kind = CameraVerdict::Kind::kIntermittent;
  } else if (v.spread > options.max_spread) {
    v.kind = CameraVerdict::Kind::kMoved;
  } else {
    v.kind = CameraVerdict::Kind::kSteady;
  }
  return v;
}

}  // namespace ips::collect
