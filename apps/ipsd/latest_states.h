// Every marker's and body's latest published state, kept by the fusion thread for the range
// input: a robot the cameras see is a mobile anchor for another robot's tag that ranges to it,
// and the reference of its own tag's track.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ips/body/body_estimate.h"
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
  void update(const std::vector<ips::FusedBody>& bodies) {
    std::lock_guard lock(mutex_);
    for (const auto& b : bodies) {
      auto [it, fresh] = bodies_.try_emplace(b.name, b);
      if (!fresh && b.t_mono_ns >= it->second.t_mono_ns) it->second = b;
    }
  }
  /// Where `tag` was at its carrier's latest published state, if ever published (range input's
  /// thread; ips::tag_point): on a marker, its height above the marker's centre; on a body, the
  /// body's origin plus the tag's offset turned by the body's orientation (held from its last
  /// measured one when ranges alone placed it), its velocity with the yaw rate's share.
  std::optional<ips::MobileReference> of(const ips::RangingTag& tag) const {
    std::lock_guard lock(mutex_);
    if (!tag.on_body()) {
      const auto it = states_.find(tag.marker);
      if (it == states_.end()) return std::nullopt;
      return ips::tag_point(it->second, Eigen::Quaterniond::Identity(), 0.0, tag);
    }
    const auto it = bodies_.find(tag.body);
    if (it == bodies_.end()) return std::nullopt;
    const ips::FusedBody& b = it->second;
    ips::MobileReference origin;
    origin.position = b.pose.position;
    if (b.has_velocity) origin.velocity = b.velocity;
    origin.covariance = b.covariance;
    origin.t_mono_ns = b.t_mono_ns;
    origin.seen_by_cameras = b.camera_mask != 0;
    return ips::tag_point(origin, b.pose.q, b.has_yaw_rate ? b.yaw_rate : 0.0, tag);
  }

 private:
  mutable std::mutex mutex_;
  std::map<int, ips::MobileReference> states_;    // bounded by the marker ids published
  std::map<std::string, ips::FusedBody> bodies_;  // bounded by the configured bodies
};

}  // namespace ipsd
