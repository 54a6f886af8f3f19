#include "ips/fusion/fixed_markers.h"

#include <algorithm>
#include <cmath>

namespace ips {

FixedMarkerMonitor::FixedMarkerMonitor(std::map<int, Eigen::Vector3d> fixed, Options options)
    : fixed_(std::move(fixed)), options_(options) {}

void FixedMarkerMonitor::configure(std::map<int, Eigen::Vector3d> fixed, Options options) {
  std::lock_guard lock(mutex_);
  const bool same = fixed == fixed_ && options.warn_m == options_.warn_m && options.window_s == options_.window_s &&
                    options.min_samples == options_.min_samples && options.back_ratio == options_.back_ratio;
  if (same) return;
  fixed_ = std::move(fixed);
  options_ = options;
  pairs_.clear();  // new positions or threshold: judge afresh (a still-moved camera warns again)
}

double FixedMarkerMonitor::median_of(const std::deque<std::pair<std::int64_t, double>>& errors) {
  std::vector<double> v;
  v.reserve(errors.size());
  for (const auto& e : errors) v.push_back(e.second);
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  if (v.size() % 2) return v[mid];
  const double upper = v[mid];
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
}

std::vector<FixedMarkerEvent> FixedMarkerMonitor::add(const FrameObservations& batch) {
  std::vector<FixedMarkerEvent> events;
  if (fixed_.empty()) return events;  // fixed_ changes only on this thread (configure)
  std::lock_guard lock(mutex_);
  const auto window_ns = static_cast<std::int64_t>(options_.window_s * 1e9);
  for (const WorldObservation& o : batch.observations) {
    const auto f = fixed_.find(o.id);
    if (f == fixed_.end() || !o.height_known || !o.p_world.allFinite()) continue;
    Pair& p = pairs_[{batch.camera_index, o.id}];
    // Horizontal distance: a tilted or shifted camera moves its markers sideways, while z is the
    // known height (plane mappers) or the depth formula's cm-level estimate (3D mappers).
    p.errors.emplace_back(o.t_mono_ns, (o.p_world - f->second).head<2>().norm());
    while (!p.errors.empty() && p.errors.front().first < o.t_mono_ns - window_ns) p.errors.pop_front();
    p.median = median_of(p.errors);
    if (p.errors.size() < options_.min_samples) continue;
    if (!p.moved && p.median > options_.warn_m) {
      p.moved = true;
      events.push_back({FixedMarkerEvent::Kind::kMoved, batch.camera_index, o.id, p.median});
    } else if (p.moved && p.median < options_.back_ratio * options_.warn_m) {
      p.moved = false;
      events.push_back({FixedMarkerEvent::Kind::kBack, batch.camera_index, o.id, p.median});
    }
  }
  return events;
}

std::vector<FixedMarkerReading> FixedMarkerMonitor::readings(std::int64_t now_mono_ns) const {
  std::lock_guard lock(mutex_);
  const auto window_ns = static_cast<std::int64_t>(options_.window_s * 1e9);
  std::vector<FixedMarkerReading> out;
  for (const auto& [key, p] : pairs_) {
    FixedMarkerReading r;
    r.camera_index = key.first;
    r.id = key.second;
    r.error_m = p.median;
    r.moved = p.moved;
    for (const auto& e : p.errors) r.samples += e.first >= now_mono_ns - window_ns;
    r.seen = r.samples > 0;
    out.push_back(r);
  }
  return out;
}

}  // namespace ips
