#include "ips/input/range_fixer.h"

#include <cmath>
#include <exception>
#include <vector>

#include "ips/ranging/multilateration.h"
#include "ips/ranging/range_observation.h"
#include "ips/ranging/speed_of_sound.h"

namespace ips {

std::optional<WorldObservation> RangeFixer::fix(const AdmittedFiring& admitted, std::int64_t t_real_ns) {
  const RangeFiring& f = admitted.firing;
  const auto tag = config_.tag_markers.find(f.tag);
  if (tag == config_.tag_markers.end()) {  // admission takes configured tags only
    ++counters_.failed["unknown_tag"];
    return std::nullopt;
  }
  std::vector<RangeToAnchor> ranges;
  ranges.reserve(f.entries.size());
  const double air =
      config_.temperature_c ? ultrasound_range_scale(*config_.temperature_c, config_.assumed_speed_of_sound) : 1.0;
  for (const RangeEntry& e : f.entries) {
    if (e.reference_is_tag) {
      const auto other = config_.tag_markers.find(e.reference);
      std::optional<MobileReference> state;
      if (other != config_.tag_markers.end() && state_of_) state = state_of_(other->second);
      const std::int64_t age = state ? admitted.t_mono_ns - state->t_mono_ns : 0;
      if (!state || age > RangeFixer::kMobileReferenceAge || age < -RangeFixer::kMobileReferenceAge) {
        ++counters_.mobile_references_unknown;
        continue;
      }
      const double dt = 1e-9 * static_cast<double>(age);
      const double sigma = e.sigma_m > 0 ? e.sigma_m : config_.sigma_m;
      const double moved = 0.5 * 1.0 * dt * dt;  // an unknown acceleration of up to 1 m/s^2
      const double reference_variance = state->covariance.trace() / 3.0 + moved * moved;
      ranges.push_back(
          {state->position + dt * state->velocity, air * e.range_m, std::sqrt(sigma * sigma + reference_variance)});
      ++counters_.mobile_references;
      continue;
    }
    const auto a = config_.anchors.find(e.reference);
    if (a == config_.anchors.end()) continue;  // admission drops these (counted there)
    const RangingAnchor& anchor = a->second;
    const double sigma = e.sigma_m > 0 ? e.sigma_m : anchor.sigma_m > 0 ? anchor.sigma_m : config_.sigma_m;
    ranges.push_back({anchor.position, (air * e.range_m - anchor.bias_m) / anchor.scale, sigma});
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
  return range_fix_observation(fix, tag->second, static_cast<int>(f.tag), admitted.t_mono_ns, t_real_ns);
}

}  // namespace ips
