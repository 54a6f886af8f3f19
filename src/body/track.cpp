// Asynchronous body fusion for the daemon (see body_track.h).
#include <algorithm>
#include <bit>
#include <cmath>

#include "ips/body/body_track.h"

namespace ips {

namespace {

FusedMarker as_marker(int body, const Eigen::Vector3d& p, std::int64_t t_ns) {
  FusedMarker m;
  m.id = body;
  m.p_world = p;
  m.t_mono_ns = t_ns;
  return m;
}

}  // namespace

BodyTrack::BodyTrack(std::vector<BodyDef> bodies, const BodyTrackOptions& options)
    : estimator_(std::move(bodies)),
      options_(options),
      tracks_(estimator_.bodies().size()),
      between_cameras_(between_cameras_options({}, options.between_cameras_process_noise)) {}

Eigen::Vector3d BodyTrack::velocity(const Track& track) {
  // Newest minus oldest published position of the path (about the span): enough to move a view forward by
  // one frame period (33 ms at 0.5 m/s is 1.7 cm; a 10 % velocity error leaves 1.7 mm).
  if (track.path.size() < 2) return Eigen::Vector3d::Zero();
  const Track::Pose& p1 = track.path.back();
  const Track::Pose& p0 = track.path.front();
  if (p1.t_ns <= p0.t_ns) return Eigen::Vector3d::Zero();
  return (p1.position - p0.position) / (1e-9 * static_cast<double>(p1.t_ns - p0.t_ns));
}

bool BodyTrack::yaw_rate(const Track& track, double& rate) {
  rate = 0.0;
  const Track::Pose* first = nullptr;
  const Track::Pose* last = nullptr;
  for (const auto& p : track.path)
    if (p.has_yaw) {
      if (!first) first = &p;
      last = &p;
    }
  if (!first || !last || last->t_ns <= first->t_ns) return false;
  // Yaw difference taken the short way round: a body turns less than half a turn in a span.
  rate = std::remainder(last->yaw - first->yaw, 2 * M_PI) / (1e-9 * static_cast<double>(last->t_ns - first->t_ns));
  return true;
}

void BodyTrack::set_velocity(const Track& track, FusedBody& f) {
  f.has_velocity = track.path.size() >= 2 && track.path.back().t_ns > track.path.front().t_ns;
  f.velocity = velocity(track);
  f.has_yaw_rate = yaw_rate(track, f.yaw_rate);
}

void BodyTrack::move_forward(BodyObservation& o, const Eigen::Vector3d& shift, double turn) {
  // Turn about the body's origin as this view placed it (a vertical axis: ground robots and
  // cubes on a floor), then move by the velocity. The marker centre turns with the body: the
  // baseline yaw of two markers seen by different cameras at different times then agrees.
  const Eigen::AngleAxisd rz(turn, Eigen::Vector3d::UnitZ());
  if (turn != 0.0 && !o.positions.empty()) {
    o.marker_centre = o.positions.front() + rz * (o.marker_centre - o.positions.front());
    o.marker_normal = rz * o.marker_normal;
    for (auto& y : o.yaws) y = std::remainder(y + turn, 2 * M_PI);
    for (auto& q : o.qs) q = Eigen::Quaterniond(rz) * q;
  }
  for (auto& p : o.positions) p += shift;
  o.marker_centre += shift;
}

void BodyTrack::add(int camera_index, std::int64_t t_mono_ns, std::int64_t t_real_ns,
                    std::span<const BodyObservation> observations, const FusionMethod& method,
                    std::vector<FusedBody>& out) {
  const auto window_ns = static_cast<std::int64_t>(options_.window_s * 1e9);
  const auto history_ns = static_cast<std::int64_t>(options_.history_s * 1e9);
  std::map<int, std::vector<BodyObservation>> by_body;
  for (const auto& o : observations)
    if (o.body >= 0 && o.body < static_cast<int>(tracks_.size())) by_body[o.body].push_back(o);

  std::vector<BodyObservation> instant;
  for (auto& [b, views] : by_body) {
    Track& track = tracks_[static_cast<std::size_t>(b)];
    auto& frames = track.by_camera[camera_index];
    // Time-ordered insert (a camera's frames normally arrive in order: append).
    auto pos = frames.end();
    while (pos != frames.begin() && std::prev(pos)->t_ns > t_mono_ns) --pos;
    frames.insert(pos, Frame{t_mono_ns, views});
    track.newest_ns = std::max(track.newest_ns, t_mono_ns);
    for (auto& [c, q] : track.by_camera)
      while (!q.empty() && q.front().t_ns < track.newest_ns - history_ns) q.pop_front();
    if (track.published && t_mono_ns < track.last.t_mono_ns) {
      ++late_;  // merged for later outputs, but this body's stream never goes back in time
      continue;
    }

    // The instant: this frame's views as they are, every other camera's newest frame at or
    // before T within the window moved forward to T (turned by the yaw rate, moved by the
    // velocity).
    const Eigen::Vector3d v = velocity(track);
    double omega = 0.0;
    yaw_rate(track, omega);
    instant.clear();
    for (const auto& [c, q] : track.by_camera) {
      const Frame* f = nullptr;
      if (c == camera_index) {
        for (const auto& fr : q)
          if (fr.t_ns == t_mono_ns) f = &fr;
      } else {
        for (const auto& fr : q)
          if (fr.t_ns <= t_mono_ns && t_mono_ns - fr.t_ns <= window_ns) f = &fr;
      }
      if (!f) continue;
      const double dt = 1e-9 * static_cast<double>(t_mono_ns - f->t_ns);
      for (BodyObservation o : f->views) {
        move_forward(o, v * dt, omega * dt);
        o.t_mono_ns = t_mono_ns;
        o.t_real_ns = t_real_ns;
        instant.push_back(std::move(o));
      }
    }
    auto fused = estimator_.fuse(instant, method);
    if (fused.empty()) continue;  // every view rejected at fusion (a cube side with no face known)
    FusedBody& f = fused.front();
    f.t_mono_ns = t_mono_ns;
    f.t_real_ns = t_real_ns;
    const double n = std::max(1, std::popcount(f.camera_mask));
    const double variance = options_.camera_sigma_m * options_.camera_sigma_m / n;
    f.covariance = (variance + f.spread * f.spread) * Eigen::Matrix3d::Identity();
    if (track.ranged) {  // the filter that carries the body where only its tag places it
      FusedMarker m = as_marker(b, f.pose.position, t_mono_ns);
      between_cameras_.update(m, Eigen::Vector3d::Constant(variance));
    }
    publish(track, f, out);
  }
  std::sort(out.begin(), out.end(), [](const FusedBody& a, const FusedBody& b) { return a.body < b.body; });
}

void BodyTrack::publish(Track& track, FusedBody& f, std::vector<FusedBody>& out) const {
  const auto span_ns = static_cast<std::int64_t>(options_.velocity_span_s * 1e9);
  track.path.push_back({f.t_mono_ns, f.pose.position, f.has_yaw, f.pose.yaw});
  // The newest pose at or before the span's start stays too (up to two spans back): the
  // velocity's baseline is then the span wherever poses reach back that far. Cut at the span,
  // a starved machine (frames dropped) left two poses a few ms apart, whose difference is
  // their noise (measured beside 4 busy loops: velocity p95 229 mm/s at 0.5 m/s).
  while (track.path.size() > 2 && track.path[1].t_ns <= f.t_mono_ns - span_ns) track.path.pop_front();
  while (track.path.size() > 1 && track.path.front().t_ns < f.t_mono_ns - 2 * span_ns) track.path.pop_front();
  set_velocity(track, f);
  track.published = true;
  track.last = f;
  out.push_back(f);
}

void BodyTrack::add_fix(const std::string& name, const Eigen::Vector3d& offset, const WorldObservation& fix,
                        double camera_hold_s, std::vector<FusedBody>& out) {
  const auto& defs = bodies();
  const auto def = std::find_if(defs.begin(), defs.end(), [&](const BodyDef& b) { return b.name == name; });
  if (def == defs.end()) return;
  const auto index = static_cast<std::size_t>(def - defs.begin());
  Track& track = tracks_[index];
  const std::int64_t t = fix.t_mono_ns;
  if (track.published && t < track.last.t_mono_ns) {
    ++late_;
    return;
  }
  // The cameras place this body, or did a moment ago and their frames are still on their way:
  // they publish it (a fix is 100 times coarser than they are).
  if (track.newest_ns > 0 && t - track.newest_ns <= static_cast<std::int64_t>(camera_hold_s * 1e9)) {
    ++held_for_cameras_;
    return;
  }
  FusedBody f;
  f.body = static_cast<int>(index);
  f.name = name;
  if (track.published) {  // the heading held: ranges say nothing of it
    f.pose.q = track.last.pose.q;
    f.pose.yaw = track.last.pose.yaw;
  }
  track.ranged = true;
  FusedMarker m = as_marker(static_cast<int>(index), fix.p_world - f.pose.q * offset, t);
  between_cameras_.update(m, fix.covariance.diagonal());
  f.pose.position = m.p_world;
  f.has_yaw = false;
  f.camera_mask = 0;
  f.sources = source_bit(ObservationSource::kRanges);
  f.covariance = m.covariance;
  f.t_mono_ns = t;
  f.t_real_ns = fix.t_real_ns;
  publish(track, f, out);
  // The filter's velocity, not the path's mean over the span (it smooths the fixes' noise).
  out.back().velocity = track.last.velocity = m.velocity;
  out.back().has_velocity = track.last.has_velocity = m.has_velocity;
}

void BodyTrack::continue_after(const BodyTrack& previous) {
  for (std::size_t i = 0; i < tracks_.size(); ++i)
    for (std::size_t j = 0; j < previous.tracks_.size(); ++j)
      if (previous.tracks_[j].published && previous.bodies()[j].name == bodies()[i].name) {
        tracks_[i].published = true;
        tracks_[i].last = previous.tracks_[j].last;
        tracks_[i].last.body = static_cast<int>(i);
      }
}

void BodyTrack::latest(std::int64_t t_mono_ns, std::vector<FusedBody>& out) const {
  const auto history_ns = static_cast<std::int64_t>(options_.history_s * 1e9);
  for (const Track& t : tracks_)
    if (t.published && t.last.t_mono_ns <= t_mono_ns && t_mono_ns - t.last.t_mono_ns <= history_ns)
      out.push_back(t.last);
}

}  // namespace ips
