#include "ips/input/range_admission.h"

#include <arpa/inet.h>

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>

#include "ips/core/error.h"

namespace ips {

namespace {

constexpr std::size_t kMaxLogged = 4096;   // distinct (reason, source) pairs logged, then quiet
constexpr std::size_t kMaxSources = 4096;  // rate buckets kept; idle ones are forgotten first

std::string endpoint(std::uint32_t address, std::uint16_t port) {
  in_addr a{};
  a.s_addr = htonl(address);
  char ip[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &a, ip, sizeof ip);
  return std::string(ip) + ":" + std::to_string(port);
}

}  // namespace

const char* range_refusal_name(RangeRefusal why) {
  switch (why) {
    case RangeRefusal::kMalformed: return "malformed";
    case RangeRefusal::kSubnet: return "subnet";
    case RangeRefusal::kKey: return "key";
    case RangeRefusal::kRate: return "rate";
    case RangeRefusal::kUnknownTag: return "unknown_tag";
    case RangeRefusal::kNoKnownReference: return "no_known_reference";
    case RangeRefusal::kClock: return "clock";
    case RangeRefusal::kDuplicate: return "duplicate";
    case RangeRefusal::kTooOld: return "too_old";
    case RangeRefusal::kCount: break;
  }
  return "?";
}

RangeAdmission::RangeAdmission(RangeInputSettings settings, const std::string& where)
    : settings_(std::move(settings)),
      where_(where),
      gate_(static_cast<std::int64_t>(std::llround(settings_.reorder_window_s * 1e9))) {
  for (std::size_t i = 0; i < settings_.allow.size(); ++i) {
    const auto s = subscription::parse_subnet(settings_.allow[i]);
    if (!s)
      throw InputError(where + ".allow[" + std::to_string(i) + "]: '" + settings_.allow[i] + "' is not an IPv4 subnet");
    allow_.push_back(*s);
  }
}

std::nullopt_t RangeAdmission::refuse(RangeRefusal why, std::uint32_t source, std::uint16_t port,
                                      const std::string& detail) {
  ++counters_.refused[static_cast<std::size_t>(why)];
  // Logged once per (reason, source address): a flood cannot fill the journal.
  const std::pair<int, std::uint32_t> key{static_cast<int>(why), source};
  if (logged_.size() <= kMaxLogged && !logged_.count(key)) {
    logged_.insert(key);
    if (logged_.size() > kMaxLogged)
      spdlog::warn("{}: refusals from more than {} sources; no more are logged (see the status counters)", where_,
                   kMaxLogged);
    else
      spdlog::warn("{}: refused a firing from {} ({}): {} (logged once per source and reason)", where_,
                   endpoint(source, port), range_refusal_name(why), detail);
  }
  return std::nullopt;
}

bool RangeAdmission::within_rate(std::uint32_t source, std::int64_t now) {
  const double rate = settings_.rate_per_source_hz;
  if (!(rate > 0)) return true;
  auto it = buckets_.find(source);
  if (it == buckets_.end()) {
    if (buckets_.size() >= kMaxSources)  // forget sources idle for a second (their bucket is full again)
      std::erase_if(buckets_, [&](const auto& b) { return now - b.second.last_ns > 1'000'000'000; });
    if (buckets_.size() >= kMaxSources) return false;
    it = buckets_.emplace(source, Bucket{rate, now}).first;
  }
  Bucket& b = it->second;
  b.tokens = std::min(rate, b.tokens + rate * 1e-9 * static_cast<double>(std::max<std::int64_t>(0, now - b.last_ns)));
  b.last_ns = now;
  if (b.tokens < 1.0) return false;
  b.tokens -= 1.0;
  return true;
}

std::optional<AdmittedFiring> RangeAdmission::admit(std::span<const std::uint8_t> bytes, std::uint32_t source,
                                                    std::uint16_t port, std::int64_t now_mono_ns,
                                                    std::int64_t now_real_ns) {
  ++counters_.datagrams;
  if (!std::any_of(allow_.begin(), allow_.end(), [&](const subscription::Subnet& s) { return s.contains(source); }))
    return refuse(RangeRefusal::kSubnet, source, port, "not in ranging.allow");
  // Before the HMAC: a flood costs a bucket lookup per datagram, not a hash.
  if (!within_rate(source, now_mono_ns))
    return refuse(RangeRefusal::kRate, source, port,
                  "more than ranging.rate_per_source (" + std::to_string(settings_.rate_per_source_hz) + " firings/s)");
  RangeDatagramError error;
  std::string why;
  auto firing = decode_range_firing(bytes, settings_.psk, error, why);
  if (!firing)
    return refuse(error == RangeDatagramError::kBadKey ? RangeRefusal::kKey : RangeRefusal::kMalformed, source, port,
                  why);
  const std::string tag = "tag " + std::to_string(firing->tag);
  if (!settings_.tags.count(firing->tag))
    return refuse(RangeRefusal::kUnknownTag, source, port, tag + " is not in ranging.tags");
  const std::size_t before = firing->entries.size();
  std::erase_if(firing->entries, [&](const RangeEntry& e) {
    return e.reference_is_tag ? !settings_.tags.count(e.reference) : !settings_.anchors.count(e.reference);
  });
  counters_.unknown_references += before - firing->entries.size();
  if (firing->entries.empty())
    return refuse(RangeRefusal::kNoKnownReference, source, port, tag + ": none of its references is configured");

  // The sender's CLOCK_REALTIME to this host's CLOCK_MONOTONIC.
  std::int64_t t = now_mono_ns;
  if (firing->firing_realtime_ns != 0) {
    const std::int64_t ahead = firing->firing_realtime_ns - now_real_ns;
    if (static_cast<double>(ahead) > settings_.max_clock_ahead_s * 1e9)
      return refuse(RangeRefusal::kClock, source, port,
                    tag + ": firing time " + std::to_string(static_cast<double>(ahead) * 1e-9) +
                        " s in the future (is the sender's clock synchronised?)");
    t = now_mono_ns + ahead;
  }
  switch (gate_.admit(firing->tag, firing->firing, t)) {
    case FiringGate::Verdict::kDuplicate:
      return refuse(RangeRefusal::kDuplicate, source, port,
                    tag + ": firing " + std::to_string(firing->firing) + " again");
    case FiringGate::Verdict::kTooOld:
      return refuse(RangeRefusal::kTooOld, source, port,
                    tag + ": firing " + std::to_string(firing->firing) + " older than ranging.reorder_window");
    case FiringGate::Verdict::kAccepted: break;
  }
  ++counters_.accepted;
  return AdmittedFiring{std::move(*firing), t, source};
}

}  // namespace ips
