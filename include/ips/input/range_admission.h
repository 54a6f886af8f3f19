// What the range input does with one received datagram, without the socket (so that the tests
// and the fuzzer drive it directly): the source's subnet, the key, the source's rate, the
// datagram's format, the tag, the references, the firing time, duplicates and order. Every
// refusal is counted by reason and logged once per (reason, source address).
// Not thread-safe: owned by the range input's receive thread.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "ips/input/firing_gate.h"
#include "ips/input/range_datagram.h"
#include "ips/output/subscription.h"

namespace ips {

/// The `ranging:` section's input part (docs/ranging.md, "The range input").
struct RangeInputSettings {
  std::string address = "0.0.0.0";                 ///< where to listen
  std::uint16_t port = 0;                          ///< UDP port; 0 = no range input
  std::vector<std::string> allow = {"0.0.0.0/0"};  ///< IPv4 subnets (CIDR) that may send
  std::string psk;                                 ///< pre-shared key for HMAC-SHA256; "" = none
  double rate_per_source_hz = 200;  ///< firings per second one source address may send (burst: one second's worth)
  double reorder_window_s = 0.3;    ///< a firing this much older than its tag's newest is too old
  double max_clock_ahead_s = 1.0;   ///< a firing time further in the future than this: the sender's clock is wrong
  std::set<std::uint32_t> tags;     ///< known tag ids
  std::set<std::uint32_t> anchors;  ///< known anchor ids

  bool operator==(const RangeInputSettings&) const = default;
};

/// Why a datagram was not taken; each is a status counter (range_refusal_name).
enum class RangeRefusal {
  kMalformed,
  kSubnet,
  kKey,
  kRate,
  kUnknownTag,
  kNoKnownReference,
  kClock,
  kDuplicate,
  kTooOld,
  kCount
};
const char* range_refusal_name(RangeRefusal why);  // "malformed", "subnet", ...

/// A firing taken: only the references the daemon knows, its time on this host's
/// CLOCK_MONOTONIC.
struct AdmittedFiring {
  RangeFiring firing;
  std::int64_t t_mono_ns = 0;
  std::uint32_t source_address = 0;  ///< IPv4, host byte order
};

struct RangeInputCounters {
  std::uint64_t datagrams = 0;  ///< every datagram received
  std::uint64_t accepted = 0;
  std::array<std::uint64_t, static_cast<std::size_t>(RangeRefusal::kCount)> refused{};
  std::uint64_t unknown_references = 0;  ///< entries dropped from taken firings (unknown anchor or tag)
};

class RangeAdmission {
 public:
  /// Throws ips::InputError naming `where` for an `allow` entry that is not a subnet.
  RangeAdmission(RangeInputSettings settings, const std::string& where);

  /// `now_mono_ns` / `now_real_ns`: this host's clocks when the datagram arrived; `source` its
  /// IPv4 address (host byte order) and port, for the rate and the log.
  std::optional<AdmittedFiring> admit(std::span<const std::uint8_t> bytes, std::uint32_t source, std::uint16_t port,
                                      std::int64_t now_mono_ns, std::int64_t now_real_ns);

  const RangeInputCounters& counters() const { return counters_; }
  const RangeInputSettings& settings() const { return settings_; }

 private:
  std::nullopt_t refuse(RangeRefusal why, std::uint32_t source, std::uint16_t port, const std::string& detail);
  bool within_rate(std::uint32_t source, std::int64_t now_mono_ns);

  struct Bucket {
    double tokens = 0;
    std::int64_t last_ns = 0;
  };
  RangeInputSettings settings_;
  std::string where_;
  std::vector<subscription::Subnet> allow_;
  FiringGate gate_;
  std::map<std::uint32_t, Bucket> buckets_;  // by source address
  std::set<std::pair<int, std::uint32_t>> logged_;
  RangeInputCounters counters_;
};

}  // namespace ips
