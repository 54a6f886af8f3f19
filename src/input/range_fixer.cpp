#include "ips/input/range_fixer.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <vector>

#include "ips/ranging/multilateration.h"
#include "ips/ranging/range_observation.h"
#include "ips/ranging/speed_of_sound.h"

namespace ips {

MobileReference point_on_body(const MobileReference& origin, const Eigen::Quaterniond& orientation, double yaw_rate,
                              const Eigen::Vector3d& offset) {
  MobileReference r = origin;
  const Eigen::Vector3d arm = orientation * offset;
  r.position += arm;
  r.velocity += Eigen::Vector3d(0, 0, yaw_rate).cross(arm);
  return r;
}

MobileReference tag_point(const MobileReference& carrier, const Eigen::Quaterniond& orientation, double yaw_rate,
                          const RangingTag& tag) {
  if (tag.on_body()) return point_on_body(carrier, orientation, yaw_rate, tag.offset);
  MobileReference r = carrier;
  r.position.z() += tag.height;
  return r;
}

RangeFixer::RangeFixer(RangingConfig config, StateOf state_of)
    : config_(std::move(config)), state_of_(std::move(state_of)), surveyor_({}, {}) {
  config_.track_options.known_height = config_.height;
  config_.track_options.z_range = config_.z_range;
  for (const auto& [id, anchor] : config_.anchors) {
    anchor_ids_.push_back(id);
    anchor_positions_.push_back(anchor.position);
  }
  surveyor_ = AnchorSurveyor(anchor_ids_, anchor_positions_);
}

void RangeFixer::survey(const std::vector<Corrected>& ranges, const AdmittedFiring& admitted, const RangingTag& tag) {
  // The cameras' state of the tag's own robot, moved to the firing time by its velocity.
  const auto seen = state_of_(tag);
  if (!seen || !seen->seen_by_cameras) return;
  const std::int64_t age = admitted.t_mono_ns - seen->t_mono_ns;
  if (age > kSurveyAge || age < -kSurveyAge) return;
  const double dt = 1e-9 * static_cast<double>(age);
  const Eigen::Vector3d at = seen->position + dt * seen->velocity;
  const double moved = 0.5 * 1.0 * dt * dt;  // an unknown acceleration of up to 1 m/s^2
  const double position_sigma = std::sqrt(seen->covariance.trace() / 3.0 + moved * moved);
  for (const Corrected& c : ranges)
    if (!c.mobile)
      if (auto event = surveyor_.add(c.anchor, at, c.range_m, std::hypot(c.sigma_m, position_sigma)))
        anchor_events_.push_back(*event);
}

std::vector<RangeFixer::Corrected> RangeFixer::correct(const AdmittedFiring& admitted) {
  const RangeFiring& f = admitted.firing;
  std::vector<Corrected> out;
  out.reserve(f.entries.size());
  const double air =
      config_.temperature_c ? ultrasound_range_scale(*config_.temperature_c, config_.assumed_speed_of_sound) : 1.0;
  for (const RangeEntry& e : f.entries) {
    if (e.reference_is_tag) {
      const auto other = config_.tags.find(e.reference);
      std::optional<MobileReference> state;
      if (other != config_.tags.end() && state_of_) state = state_of_(other->second);
      const std::int64_t age = state ? admitted.t_mono_ns - state->t_mono_ns : 0;
      Corrected c;
      c.mobile = true;
      c.other_tag = e.reference;
      c.range_m = air * e.range_m;
      c.sigma_m = e.sigma_m > 0 ? e.sigma_m : config_.sigma_m;
      c.placed_by_cameras = state && state->seen_by_cameras && std::abs(age) <= kCameraReferenceAge;
      if (!state || age > RangeFixer::kMobileReferenceAge || age < -RangeFixer::kMobileReferenceAge) {
        // Of no use to this tag; the other tag's own track may still take it (track.mutual).
        ++counters_.mobile_references_unknown;
        c.reference_known = false;
        if (other != config_.tags.end()) out.push_back(c);
        continue;
      }
      const double dt = 1e-9 * static_cast<double>(age);
      const double moved = 0.5 * 1.0 * dt * dt;  // an unknown acceleration of up to 1 m/s^2
      c.reference = state->position + dt * state->velocity;
      c.reference_sigma_m = std::sqrt(state->covariance.trace() / 3.0 + moved * moved);
      out.push_back(c);
      ++counters_.mobile_references;
      continue;
    }
    const auto a = config_.anchors.find(e.reference);
    if (a == config_.anchors.end()) continue;  // admission drops these (counted there)
    const RangingAnchor& anchor = a->second;
    Corrected c;
    c.anchor = static_cast<std::size_t>(std::distance(config_.anchors.begin(), a));
    c.reference = anchor.position;
    c.range_m = (air * e.range_m - anchor.bias_m) / anchor.scale;
    c.sigma_m = e.sigma_m > 0 ? e.sigma_m : anchor.sigma_m > 0 ? anchor.sigma_m : config_.sigma_m;
    out.push_back(c);
  }
  return out;
}

std::optional<WorldObservation> RangeFixer::fix(const AdmittedFiring& admitted, std::int64_t t_real_ns) {
  const auto tag = config_.tags.find(admitted.firing.tag);
  if (tag == config_.tags.end()) {  // admission takes configured tags only
    ++counters_.failed["unknown_tag"];
    return std::nullopt;
  }
  const std::vector<Corrected> ranges = correct(admitted);
  if (config_.track_camera_reference && state_of_) survey(ranges, admitted, tag->second);
  auto out =
      config_.track ? track(ranges, admitted, tag->second, t_real_ns) : solve(ranges, admitted, tag->second, t_real_ns);
  remember_firing(admitted, out);  // the tag's own position: its next firing's odometry sphere
  if (out && !tag->second.on_body()) out->p_world.z() -= tag->second.height;  // the marker's centre
  return out;
}

const RangeFixer::PastFiring* RangeFixer::previous_firing(const AdmittedFiring& admitted) const {
  const auto tag = past_firings_.find(admitted.firing.tag);
  if (tag == past_firings_.end()) return nullptr;
  const auto previous = tag->second.find(admitted.firing.firing - 1);  // wraps with the counter
  if (previous == tag->second.end() || previous->second.t_ns >= admitted.t_mono_ns) return nullptr;
  return &previous->second;
}

void RangeFixer::remember_firing(const AdmittedFiring& admitted, const std::optional<WorldObservation>& fix) {
  auto& firings = past_firings_[admitted.firing.tag];
  PastFiring& past = firings[admitted.firing.firing];
  past.t_ns = admitted.t_mono_ns;
  if (fix) past.fix = MobileReference{fix->p_world, Eigen::Vector3d::Zero(), fix->covariance, fix->t_mono_ns, false};
  // A firing's odometry refers to the one just before it: 2 s of them is plenty, whatever the
  // rate or the arrival order.
  std::erase_if(firings, [&](const auto& f) { return f.second.t_ns < admitted.t_mono_ns - 2'000'000'000; });
}

double RangeFixer::odometry_sigma(const RangeFiring& firing) {
  // A sender that states no sigma: 1 mm, about what wheel encoders give over one firing.
  return firing.odometry_sigma_m > 0 ? firing.odometry_sigma_m : 1e-3;
}

std::optional<WorldObservation> RangeFixer::solve(const std::vector<Corrected>& corrected,
                                                  const AdmittedFiring& admitted, const RangingTag& tag,
                                                  std::int64_t t_real_ns) {
  std::vector<RangeToAnchor> ranges;
  ranges.reserve(corrected.size() + 1);
  for (const Corrected& c : corrected)
    if (c.reference_known) ranges.push_back({c.reference, c.range_m, std::hypot(c.sigma_m, c.reference_sigma_m)});
  if (const RangeFiring& f = admitted.firing; f.odometry_m) {
    // The distance travelled is a range to where the previous firing put the tag.
    const PastFiring* previous = previous_firing(admitted);
    if (previous && previous->fix) {
      const double previous_sigma = std::sqrt(previous->fix->covariance.trace() / 3.0);
      ranges.push_back(
          {previous->fix->position, std::max(*f.odometry_m, 1e-3), std::hypot(odometry_sigma(f), previous_sigma)});
      ++counters_.odometry["sphere"];
    } else {
      ++counters_.odometry["no_previous"];
    }
  }
  RangeSolveOptions options;
  options.known_height = config_.height;
  options.z_range = config_.z_range;
  RangeFix fix;
  try {
    fix = fix_by_method(config_.method, ranges, options, "ranging.method");
  } catch (const std::exception&) {  // a solver's own failure: one firing lost, the input goes on
    fix.ok = false;
    fix.status = RangeFixStatus::kFailed;
  }
  if (!fix.ok) {
    ++counters_.failed[range_fix_status_word(fix.status)];
    return std::nullopt;
  }
  ++counters_.fixes;
  return range_fix_observation(fix, tag.marker, static_cast<int>(admitted.firing.tag), admitted.t_mono_ns, t_real_ns);
}

std::optional<WorldObservation> RangeFixer::track(const std::vector<Corrected>& corrected,
                                                  const AdmittedFiring& admitted, const RangingTag& tag,
                                                  std::int64_t t_real_ns) {
  RangeTracker& tracker = tracker_of(admitted.firing.tag);
  const std::int64_t t = admitted.t_mono_ns;
  // The cameras' view of this tag's own robot, once per camera-placed state: a position
  // measurement at its own time (the track applies it in its place among the ranges).
  if (config_.track_camera_reference && state_of_) {
    const auto seen = state_of_(tag);
    std::int64_t& used_ns = camera_reference_used_[admitted.firing.tag];
    if (seen && seen->seen_by_cameras && seen->t_mono_ns > used_ns &&
        std::abs(t - seen->t_mono_ns) <= kCameraReferenceAge) {
      used_ns = seen->t_mono_ns;
      const RangeUpdate u = tracker.add_position(seen->t_mono_ns, seen->position, seen->covariance);
      if (u == RangeUpdate::kAccepted || u == RangeUpdate::kStarted) ++counters_.camera_references;
    }
  }
  // This tag's state before its own ranges: the reference its ranges to other tags give them.
  const std::optional<RangeTrackState> before = config_.track_mutual ? tracker.state_at(t) : std::nullopt;
  bool used = false;
  for (const Corrected& c : corrected) {
    if (before && c.mobile) share_range(c, *before, t);
    if (!c.reference_known) continue;
    const RangeUpdate u = c.mobile ? tracker.add_mobile_range(t, c.reference, c.reference_sigma_m, c.range_m, c.sigma_m)
                                   : tracker.add_anchor_range(t, c.anchor, c.range_m, c.sigma_m);
    ++counters_.ranges[range_update_word(u)];
    used = used || u == RangeUpdate::kAccepted || u == RangeUpdate::kStarted;
  }
  if (const RangeFiring& f = admitted.firing; f.odometry_m) {
    // The distance travelled since the previous firing over the time between them: a speed.
    const PastFiring* previous = previous_firing(admitted);
    if (previous) {
      const double dt = 1e-9 * static_cast<double>(t - previous->t_ns);
      ++counters_.odometry[range_update_word(tracker.add_speed(t, *f.odometry_m / dt, odometry_sigma(f) / dt))];
    } else {
      ++counters_.odometry["no_previous"];
    }
  }
  const auto state = used ? tracker.state_at(t) : std::nullopt;
  if (!state) {
    // Nothing of this firing moved the track: still gathering its first fix, or every range
    // left out (by the gate, or older than the reorder window).
    ++counters_.failed[tracker.started() ? "ranges_left_out" : "initialising"];
    return std::nullopt;
  }
  RangeFix fix;
  fix.ok = true;
  fix.status = RangeFixStatus::kOk;
  fix.position = state->position;
  fix.covariance = state->covariance;
  ++counters_.fixes;
  return range_fix_observation(fix, tag.marker, static_cast<int>(admitted.firing.tag), t, t_real_ns);
}

RangeTracker& RangeFixer::tracker_of(std::uint32_t tag) {
  return trackers_.try_emplace(tag, anchor_positions_, config_.track_options).first->second;
}

void RangeFixer::share_range(const Corrected& c, const RangeTrackState& from, std::int64_t t_ns) {
  // Where the cameras place the other robot its track takes their position instead: the
  // range would add little, and the two tracks' errors would no longer be independent.
  if (c.placed_by_cameras) return;
  RangeTracker& tracker = tracker_of(c.other_tag);
  // The firing tag's uncertainty along the line to the other (the only direction a range
  // measures); before the other's track has a state, the mean over the axes.
  double variance = from.covariance.trace() / 3.0;
  if (const auto to = tracker.state_at(t_ns); to && (to->position - from.position).norm() > 1e-3) {
    const Eigen::Vector3d u = (to->position - from.position).normalized();
    variance = u.dot(from.covariance * u);
  }
  const RangeUpdate u = tracker.add_mobile_range(t_ns, from.position, std::sqrt(variance), c.range_m, c.sigma_m);
  ++counters_.mutual[range_update_word(u)];
}

std::vector<RangeTrackSummary> RangeFixer::tracks() const {
  std::vector<RangeTrackSummary> out;
  for (const auto& [tag, tracker] : trackers_) {
    RangeTrackSummary s;
    s.tag = tag;
    s.started = tracker.started();
    s.restarts = tracker.restarts();
    s.replayed = tracker.replayed();
    s.learning_bias = tracker.learning_bias();
    {
      const std::vector<double> b = tracker.biases();
      for (std::size_t i = 0; i < b.size() && i < anchor_ids_.size(); ++i) s.biases_m[anchor_ids_[i]] = b[i];
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace ips
