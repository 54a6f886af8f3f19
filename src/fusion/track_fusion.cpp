#include "ips/fusion/track_fusion.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <set>

#include <Eigen/Dense>

namespace ips {
namespace {

std::int64_t to_ns(double s) { return static_cast<std::int64_t>(std::llround(s * 1e9)); }

// Frames of one camera fitted for its velocity, at most.
constexpr std::size_t kVelocityFrames = 3;
// Capture times this close count as the same instant (no motion compensation needed).
constexpr std::int64_t kSameInstantNs = 1'000'000;

// Least-squares slope of position against time over `obs` (>= 2 distinct times), m/s.
Eigen::Vector3d fitted_velocity(const std::vector<const WorldObservation*>& obs) {
  double t_mean = 0.0;
  Eigen::Vector3d p_mean = Eigen::Vector3d::Zero();
  const std::int64_t t0 = obs.front()->t_mono_ns;
  for (const auto* o : obs) {
    t_mean += 1e-9 * static_cast<double>(o->t_mono_ns - t0);
    p_mean += o->p_world;
  }
  const double n = static_cast<double>(obs.size());
  t_mean /= n;
  p_mean /= n;
  double stt = 0.0;
  Eigen::Vector3d stp = Eigen::Vector3d::Zero();
  for (const auto* o : obs) {
    const double dt = 1e-9 * static_cast<double>(o->t_mono_ns - t0) - t_mean;
    stt += dt * dt;
    stp += dt * (o->p_world - p_mean);
  }
  return stt > 0.0 ? Eigen::Vector3d(stp / stt) : Eigen::Vector3d::Zero();
}

// Least-squares point nearest to the rays (origin, unit direction) of `e`: minimises the sum
// of squared perpendicular distances. False when the rays are (nearly) parallel.
bool triangulate(const std::vector<WorldObservation>& e, Eigen::Vector3d& p, Eigen::Matrix3d& A_inv) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& o : e) {
    const Eigen::Matrix3d M = Eigen::Matrix3d::Identity() - o.ray_direction * o.ray_direction.transpose();
    A += M;
    b += M * o.ray_origin;
  }
  // Two rays 5 degrees apart give a smallest eigenvalue ~ sin^2(5 deg)/2 ~ 4e-3.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
  if (!(eig.eigenvalues().minCoeff() > 1e-3)) return false;
  A_inv = A.inverse();
  p = A_inv * b;
  return p.allFinite();
}

double ray_distance(const WorldObservation& o, const Eigen::Vector3d& p) {
  const Eigen::Vector3d r = p - o.ray_origin;
  return (r - r.dot(o.ray_direction) * o.ray_direction).norm();
}

// A stream is one camera, or one stream of another source (a ranging tag): its estimates are
// fitted for velocity together. Other sources' streams are kept apart from camera indices.
int stream_key(const WorldObservation& o) {
  if (o.source == ObservationSource::kCamera) return o.camera_index;
  return (static_cast<int>(o.source) << 24) | (o.camera_index & 0xFFFFFF);
}

struct Gaussian {
  Eigen::Vector3d mean;
  Eigen::Matrix3d covariance;
};

// Inverse-covariance weighted mean. A zero variance (a fix at a known height) is floored at
// (0.1 mm)^2 rather than made infinitely certain.
Gaussian information_mean(const std::vector<Gaussian>& parts) {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& g : parts) {
    const Eigen::Matrix3d w = (g.covariance + 1e-8 * Eigen::Matrix3d::Identity()).inverse();
    information += w;
    sum += w * g.mean;
  }
  const Eigen::Matrix3d covariance = information.inverse();
  return {covariance * sum, covariance};
}

}  // namespace

TrackFusion::TrackFusion(const TrackFusionOptions& options)
    : options_(options),
      between_cameras_(between_cameras_options(options.kalman_options, options.between_cameras_process_noise)) {
  if (options_.kalman) kalman_.emplace(options_.kalman_options);
}

// The time a history of this kind reaches back from: the cameras' from their newest frame,
// the other sources' from the newest observation of any. Camera frames reach fusion later than
// a range fix of the same instant (decoding, detection; much later on a busy machine) and must
// not be dropped as old for that.
std::int64_t TrackFusion::newest_of_kind(const Track& track, ObservationSource source) {
  if (source != ObservationSource::kCamera) return track.newest_ns;
  // No camera frame yet: the first is never too old (far in the past, without overflow).
  return track.camera_newest_ns != INT64_MIN ? track.camera_newest_ns : INT64_MIN / 2;
}

void TrackFusion::prune(Track& track) const {
  const std::int64_t history = to_ns(options_.history_s);
  for (auto it = track.by_camera.begin(); it != track.by_camera.end();) {
    auto& q = it->second;
    const std::int64_t oldest = q.empty() ? 0 : newest_of_kind(track, q.front().source) - history;
    while (!q.empty() && q.front().t_mono_ns < oldest) q.pop_front();
    it = q.empty() ? track.by_camera.erase(it) : std::next(it);
  }
}

std::vector<WorldObservation> TrackFusion::estimates_at(const Track& track, std::int64_t t, std::int64_t t_real,
                                                        std::int64_t window, Eigen::Vector3d& camera_v,
                                                        int& camera_v_count, Eigen::Vector3d& other_v,
                                                        int& other_v_count) const {
  const std::int64_t span = to_ns(options_.velocity_span_s);
  std::vector<WorldObservation> estimates;
  for (const auto& [stream, q] : track.by_camera) {
    // This stream's newest capture time at or before t (several sightings may share it).
    auto last = std::upper_bound(q.begin(), q.end(), t,
                                 [](std::int64_t x, const WorldObservation& o) { return x < o.t_mono_ns; });
    if (last == q.begin()) continue;
    const std::int64_t t_cam = std::prev(last)->t_mono_ns;
    if (t - t_cam > window) continue;
    // Velocity from this camera's newest kVelocityFrames frames within the span (one
    // observation per frame: the first sighting of each capture time, so an impostor does not
    // weigh twice). Few frames keep the lag on curves small; the span lets a starved camera
    // (frames skipped) still have a velocity.
    std::vector<const WorldObservation*> fit;
    for (auto it = last; it != q.begin() && fit.size() < kVelocityFrames;) {
      --it;
      if (t_cam - it->t_mono_ns > span) break;
      if (!fit.empty() && fit.back()->t_mono_ns == it->t_mono_ns) continue;
      fit.push_back(&*it);
    }
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    if (fit.size() >= 2) {
      if (!fit.front()->height_known) {
        // Rays without a height: their depth-formula points are too noisy to fit, but where
        // the rays meet the plane of the marker's last fused z (it drives on a floor) they
        // move like the marker does (before the first fused z: the depth formula's).
        const double z = track.path.empty() ? fit.front()->p_world.z() : track.path.back().second.z();
        std::vector<WorldObservation> on_plane;
        on_plane.reserve(fit.size());
        for (const auto* o : fit) {
          WorldObservation w = *o;
          if (o->has_ray && std::fabs(o->ray_direction.z()) > 1e-6)
            w.p_world = o->ray_origin + (z - o->ray_origin.z()) / o->ray_direction.z() * o->ray_direction;
          on_plane.push_back(w);
        }
        std::vector<const WorldObservation*> ptrs;
        for (const auto& w : on_plane) ptrs.push_back(&w);
        v = fitted_velocity(ptrs);
      } else {
        v = fitted_velocity(fit);
      }
      const bool from_camera = fit.front()->source == ObservationSource::kCamera;
      (from_camera ? camera_v : other_v) += v;
      ++(from_camera ? camera_v_count : other_v_count);
    }
    const double dt = 1e-9 * static_cast<double>(t - t_cam);
    // An estimate that cannot be motion-compensated (one frame of this camera) is used only
    // at its own instant: another frame's velocity (the fused path's) proved too rough to move it.
    if (fit.size() < 2 && t - t_cam > kSameInstantNs) continue;
    for (auto it = last; it != q.begin();) {
      --it;
      if (it->t_mono_ns != t_cam) break;
      WorldObservation e = *it;
      e.p_world += v * dt;  // moved to the output time
      e.ray_origin += v * dt;
      e.t_mono_ns = t;
      e.t_real_ns = t_real;
      estimates.push_back(e);
    }
  }
  return estimates;
}

std::optional<FusedMarker> TrackFusion::camera_state(int id, const Track& track,
                                                     std::vector<WorldObservation> estimates, std::int64_t t,
                                                     std::int64_t t_real, const FusionMethod& method,
                                                     const std::optional<Eigen::Vector3d>& velocity) const {
  // Known heights win; without, rays of >= 2 cameras are triangulated, one camera's
  // depth-formula estimate is used only if allowed.
  if (std::any_of(estimates.begin(), estimates.end(), [](const WorldObservation& e) { return e.height_known; }))
    std::erase_if(estimates, [](const WorldObservation& e) { return !e.height_known; });
  if (estimates.empty()) return std::nullopt;
  if (!estimates.front().height_known) {
    std::set<int> cameras;
    for (const auto& e : estimates) cameras.insert(e.camera_index);
    Eigen::Vector3d p;
    Eigen::Matrix3d A_inv;
    if (cameras.size() >= 2 && triangulate(estimates, p, A_inv)) {
      FusedMarker f = fuse_marker(estimates, method);  // mask, quality, yaw
      f.id = id;
      f.p_world = p;
      f.t_mono_ns = t;
      f.t_real_ns = t_real;
      // Spread = the largest ray residual; covariance = residual variance (at least one
      // measurement variance) through the ray geometry.
      double sq = 0.0;
      f.spread = 0.0;
      for (const auto& e : estimates) {
        const double r = ray_distance(e, p);
        f.spread = std::max(f.spread, r);
        sq += r * r;
      }
      f.covariance =
          std::max(sq / static_cast<double>(estimates.size()), options_.kalman_options.measurement_noise) * A_inv;
      f.velocity = path_velocity(track);
      f.has_velocity = track.path.size() >= 2;
      return f;
    }
    if (cameras.size() >= 2 || !options_.single_camera_depth) return std::nullopt;
  }
  FusedMarker f = fuse_marker(estimates, method);
  f.id = id;
  f.t_mono_ns = t;
  f.t_real_ns = t_real;
  if (velocity) {
    f.velocity = *velocity;
    f.has_velocity = true;
  }
  // Covariance without a filter: scatter of the estimates + one measurement variance, / n.
  const double n = static_cast<double>(estimates.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& e : estimates) scatter += (e.p_world - f.p_world) * (e.p_world - f.p_world).transpose();
  f.covariance = (scatter / n + options_.kalman_options.measurement_noise * Eigen::Matrix3d::Identity()) / n;
  return f;
}

std::optional<FusedMarker> TrackFusion::state_at(int id, const Track& track, std::int64_t t, std::int64_t t_real,
                                                 std::int64_t window, const FusionMethod& method) const {
  Eigen::Vector3d camera_v = Eigen::Vector3d::Zero(), other_v = Eigen::Vector3d::Zero();
  int camera_v_count = 0, other_v_count = 0;
  std::vector<WorldObservation> cameras =
      estimates_at(track, t, t_real, window, camera_v, camera_v_count, other_v, other_v_count);
  const auto first_other = std::stable_partition(
      cameras.begin(), cameras.end(), [](const WorldObservation& e) { return e.source == ObservationSource::kCamera; });
  const std::vector<WorldObservation> others(first_other, cameras.end());
  cameras.erase(first_other, cameras.end());
  std::optional<Eigen::Vector3d> camera_velocity;
  if (camera_v_count > 0) camera_velocity = camera_v / camera_v_count;
  std::optional<FusedMarker> seen =
      cameras.empty() ? std::nullopt : camera_state(id, track, std::move(cameras), t, t_real, method, camera_velocity);
  if (others.empty()) return seen;

  // Other sources by their covariances; the cameras' estimate enters as one more, with
  // camera_sigma_m per axis over the number of cameras.
  std::vector<Gaussian> parts;
  for (const auto& e : others) parts.push_back({e.p_world, e.covariance});
  FusedMarker f;
  if (seen) {
    f = *seen;
    const double n = std::max(1, std::popcount(f.camera_mask));
    parts.push_back({f.p_world, options_.camera_sigma_m * options_.camera_sigma_m / n * Eigen::Matrix3d::Identity()});
  } else {
    f = fuse_marker(others, method);  // sources, heading (if any), time
    f.id = id;
    f.t_mono_ns = t;
    f.t_real_ns = t_real;
    if (other_v_count > 0) {
      f.velocity = other_v / other_v_count;
      f.has_velocity = true;
    } else if (track.path.size() >= 2) {
      f.velocity = path_velocity(track);
      f.has_velocity = true;
    }
  }
  for (const auto& e : others) f.sources |= source_bit(e.source);
  const Gaussian g = information_mean(parts);
  f.p_world = g.mean;
  f.covariance = g.covariance;
  f.spread = 0.0;
  for (const auto& part : parts) f.spread = std::max(f.spread, (part.mean - g.mean).norm());
  return f;
}

Eigen::Vector3d TrackFusion::path_velocity(const Track& track) const {
  if (track.path.size() < 2) return Eigen::Vector3d::Zero();
  std::vector<WorldObservation> pts(track.path.size());
  std::vector<const WorldObservation*> ptrs;
  for (std::size_t i = 0; i < track.path.size(); ++i) {
    pts[i].t_mono_ns = track.path[i].first;
    pts[i].p_world = track.path[i].second;
    ptrs.push_back(&pts[i]);
  }
  return fitted_velocity(ptrs);
}

void TrackFusion::finish(FusedMarker& f, Track& track) {
  FusedMarker filtered = f;
  if (f.camera_mask) {
    if (track.other_sources) {  // a camera-only object never needs the hand-over
      const double n = std::max(1, std::popcount(f.camera_mask));
      between_cameras_.update(filtered,
                              Eigen::Vector3d::Constant(options_.camera_sigma_m * options_.camera_sigma_m / n));
    }
  } else if (f.sources & ~source_bit(ObservationSource::kCamera)) {
    between_cameras_.update(filtered, f.covariance.diagonal());
    f.p_world = filtered.p_world;
    f.covariance = filtered.covariance;
    f.velocity = filtered.velocity;
    f.has_velocity = true;
  }
  // The path keeps the unfiltered states of the last velocity span (x2: several cameras' worth).
  track.path.emplace_back(f.t_mono_ns, f.p_world);
  while (track.path.size() > 2 && f.t_mono_ns - track.path.front().first > to_ns(2 * options_.velocity_span_s))
    track.path.pop_front();
  if (f.has_yaw)
    track.yaw = f.yaw;
  else
    f.yaw = track.yaw;  // held: ranges alone say nothing of the heading
  if (kalman_) kalman_->update(f);
  track.published_ns = f.t_mono_ns;
  track.published = true;
}

void TrackFusion::add(const FrameObservations& batch, const FusionMethod& method, std::vector<FusedMarker>* out) {
  const std::int64_t t = batch.t_mono_ns;
  const std::int64_t history = to_ns(options_.history_s);
  // Older than every history: a track dropped for being idle must not restart in the past.
  const bool camera = batch.camera_index >= 0;
  if (t < (camera ? latest_camera_ns_ : latest_ns_) - history) {
    counters_.too_old += batch.observations.size();
    return;
  }
  latest_ns_ = std::max(latest_ns_, t);
  if (camera) latest_camera_ns_ = std::max(latest_camera_ns_, t);
  if (batch.camera_index >= 0 && batch.t_fusion_ns > 0) camera_lag_.add(t, batch.t_fusion_ns);
  const std::int64_t hold = to_ns(effective_camera_hold_s());
  std::vector<int> seen;
  for (const WorldObservation& o : batch.observations) {
    Track& track = tracks_[o.id];
    if (o.t_mono_ns < newest_of_kind(track, o.source) - history) {
      ++counters_.too_old;
      continue;
    }
    auto& q = track.by_camera[stream_key(o)];
    auto pos = std::upper_bound(q.begin(), q.end(), o.t_mono_ns,
                                [](std::int64_t x, const WorldObservation& w) { return x < w.t_mono_ns; });
    q.insert(pos, o);
    track.newest_ns = std::max(track.newest_ns, o.t_mono_ns);
    track.other_sources |= o.source != ObservationSource::kCamera;
    if (o.source == ObservationSource::kCamera) track.camera_newest_ns = std::max(track.camera_newest_ns, o.t_mono_ns);
    prune(track);
    seen.push_back(o.id);
  }
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  for (int id : out ? seen : std::vector<int>{}) {
    Track& track = tracks_[id];
    if (track.published && t < track.published_ns) {  // late: merged, not published
      ++counters_.late;
      continue;
    }
    const bool camera_saw_it_now =
        std::any_of(batch.observations.begin(), batch.observations.end(),
                    [&](const WorldObservation& o) { return o.id == id && o.source == ObservationSource::kCamera; });
    if (!camera_saw_it_now && track.camera_newest_ns != INT64_MIN && track.camera_newest_ns >= t - hold) {
      ++counters_.held_for_cameras;  // the cameras' next record carries it
      continue;
    }
    auto f = state_at(id, track, t, batch.t_real_ns, to_ns(options_.window_s), method);
    if (!f) continue;
    finish(*f, track);
    out->push_back(*f);
  }
  // Forget objects not seen for twice the history (bounded memory with changing ids).
  for (auto it = tracks_.begin(); it != tracks_.end();)
    it =
        it->second.newest_ns < (it->second.camera_newest_ns != INT64_MIN ? latest_camera_ns_ : latest_ns_) - 2 * history
            ? tracks_.erase(it)
            : std::next(it);
}

double TrackFusion::effective_camera_hold_s() const {
  if (options_.camera_hold_s <= 0) return 0.0;  // configured off: stays off
  return std::max(options_.camera_hold_s, 1.5e-9 * static_cast<double>(camera_lag_.max_ns()));
}

void TrackFusion::predict_all(std::int64_t t, std::int64_t t_real, const FusionMethod& method,
                              std::vector<FusedMarker>& out) {
  for (auto& [id, track] : tracks_) {
    if (track.published && t < track.published_ns) continue;
    auto f = state_at(id, track, t, t_real, to_ns(options_.history_s), method);
    if (!f) continue;
    finish(*f, track);
    out.push_back(*f);
  }
}

}  // namespace ips
