// A firing taken by the range input -> a world observation for fusion: its ranges corrected by
// each anchor's bias and scale, solved by the configured method, and published as the tag's
// marker. Firings that cannot be solved are counted by the reason's word.
// Not thread-safe: owned by the range input's receive thread (counters() under the caller's lock).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "ips/core/observation.h"
#include "ips/input/range_admission.h"
#include "ips/input/ranging_settings.h"

namespace ips {

struct RangeFixCounters {
  std::uint64_t fixes = 0;                      ///< firings solved and handed to fusion
  std::map<std::string, std::uint64_t> failed;  ///< firings not solved, by range_fix_status_word
  /// Entries ranging to another tag: not used yet (a robot as a mobile anchor needs its
  /// published position; docs/ranging.md).
  std::uint64_t tag_references_skipped = 0;
};

class RangeFixer {
 public:
  explicit RangeFixer(RangingConfig config) : config_(std::move(config)) {}

  /// The observation of `firing`'s tag at its firing time, or nullopt (counted) if it cannot
  /// be solved. `t_real_ns` is the firing time on this host's CLOCK_REALTIME.
  std::optional<WorldObservation> fix(const AdmittedFiring& firing, std::int64_t t_real_ns);

  const RangeFixCounters& counters() const { return counters_; }
  const RangingConfig& config() const { return config_; }

 private:
  RangingConfig config_;
  RangeFixCounters counters_;
};

}  // namespace ips
