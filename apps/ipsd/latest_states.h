// Every marker's latest published state, kept by the fusion thread for the range input: a
// robot the cameras see is a mobile anchor for another robot's tag that ranges to it.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "ips/fusion/fusion.h"
#include "ips/input/range_fixer.h"

namespace ipsd {

class LatestStates {
 public:
  /// The states of one published update (fusion thread).
  void update(const std::vector<ips::FusedMarker>& states) {
    std::lock_guard lock(mutex_);
    for (const auto& f : states) {
      ips::MobileReference& r = states_[f.id];
      if (f.t_mono_ns < r.t_mono_ns) continue;
      r.position = f.p_world;
      r.velocity = f.has_velocity ? f.velocity : Eigen::Vector3d::Zero();
      r.covariance = f.covariance;
      r.t_mono_ns = f.t_mono_ns;
      r.seen_by_cameras = f.camera_mask != 0;
    }
  }
  /// Marker `id`'s latest state, if it was ever published (range input's thread).
  std::optional<ips::MobileReference> of(int id) const {
    std::lock_guard lock(mutex_);
    const auto it = states_.find(id);
    if (it == states_.end()) return std::nullopt;
    return it->second;
  }

 private:
  mutable std::mutex mutex_;
  std::map<int, ips::MobileReference> states_;  // bounded by the marker ids published
};

}  // namespace ipsd
