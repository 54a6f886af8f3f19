#include "ips/input/range_datagram.h"

#include <cmath>
#include <cstring>
#include <set>
#include <stdexcept>

#include <sodium.h>

#include "ips/input/range_wire.h"
#include "ips/output/subscription.h"

namespace ips {

namespace {

std::span<const std::uint8_t> as_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

bool valid_range(double r) { return std::isfinite(r) && r >= 0 && r <= IPS_RANGE_MAX_RANGE_M; }
bool valid_sigma(double s) { return std::isfinite(s) && s >= 0 && s <= IPS_RANGE_MAX_RANGE_M; }

}  // namespace

std::vector<std::uint8_t> encode_range_firing(const RangeFiring& f, const std::string& psk) {
  if (f.entries.empty() || f.entries.size() > IPS_RANGE_MAX_ENTRIES)
    throw std::invalid_argument("a firing carries 1 to " + std::to_string(IPS_RANGE_MAX_ENTRIES) + " ranges, not " +
                                std::to_string(f.entries.size()));
  if (f.tag & IPS_RANGE_REF_TAG) throw std::invalid_argument("tag ids are below 2^31");
  if (f.odometry_m && (!valid_range(*f.odometry_m) || !valid_sigma(f.odometry_sigma_m)))
    throw std::invalid_argument("odometry out of range");
  // Written into fixed arrays, then appended (GCC cannot see a vector's data() is not null).
  std::uint8_t h[IPS_RANGE_HEADER_SIZE] = {};
  std::memcpy(h + IPS_RANGE_OFF_MAGIC, IPS_RANGE_MAGIC, 4);
  h[IPS_RANGE_OFF_VERSION] = IPS_RANGE_VERSION;
  h[IPS_RANGE_OFF_FLAGS] = f.odometry_m ? IPS_RANGE_FLAG_ODOMETRY : 0;
  ips_wire_put_u16(h + IPS_RANGE_OFF_ENTRY_COUNT, static_cast<std::uint16_t>(f.entries.size()));
  ips_wire_put_u32(h + IPS_RANGE_OFF_TAG, f.tag);
  ips_wire_put_u32(h + IPS_RANGE_OFF_FIRING, f.firing);
  ips_wire_put_i64(h + IPS_RANGE_OFF_FIRING_REALTIME, f.firing_realtime_ns);
  ips_wire_put_u16(h + IPS_RANGE_OFF_ENTRY_SIZE, IPS_RANGE_ENTRY_SIZE);
  ips_wire_put_f32(h + IPS_RANGE_OFF_ODOMETRY, static_cast<float>(f.odometry_m.value_or(0.0)));
  ips_wire_put_f32(h + IPS_RANGE_OFF_ODOMETRY_SIGMA, static_cast<float>(f.odometry_m ? f.odometry_sigma_m : 0.0));
  std::vector<std::uint8_t> b(h, h + sizeof h);
  for (const RangeEntry& r : f.entries) {
    if (r.reference & IPS_RANGE_REF_TAG) throw std::invalid_argument("reference ids are below 2^31");
    if (!valid_range(r.range_m) || !valid_sigma(r.sigma_m))
      throw std::invalid_argument("range or sigma out of range for reference " + std::to_string(r.reference));
    std::uint8_t e[IPS_RANGE_ENTRY_SIZE];
    ips_wire_put_u32(e + IPS_RANGE_ENTRY_REFERENCE, r.reference | (r.reference_is_tag ? IPS_RANGE_REF_TAG : 0u));
    ips_wire_put_f32(e + IPS_RANGE_ENTRY_RANGE, static_cast<float>(r.range_m));
    ips_wire_put_f32(e + IPS_RANGE_ENTRY_SIGMA, static_cast<float>(r.sigma_m));
    b.insert(b.end(), e, e + sizeof e);
  }
  if (!psk.empty()) {
    const subscription::Mac mac = subscription::hmac_sha256(as_bytes(psk), b);
    b.insert(b.end(), mac.begin(), mac.end());
  }
  return b;
}

std::optional<RangeFiring> decode_range_firing(std::span<const std::uint8_t> bytes, const std::string& psk,
                                               RangeDatagramError& error, std::string& why) {
  error = RangeDatagramError::kMalformed;
  const auto refuse = [&](std::string reason) -> std::optional<RangeFiring> {
    why = std::move(reason);
    return std::nullopt;
  };
  if (bytes.size() < IPS_RANGE_HEADER_SIZE) return refuse("shorter than the header");
  if (std::memcmp(bytes.data(), IPS_RANGE_MAGIC, 4) != 0) return refuse("not a range datagram (magic)");
  const std::uint8_t* h = bytes.data();
  if (h[IPS_RANGE_OFF_VERSION] != IPS_RANGE_VERSION)
    return refuse("version " + std::to_string(h[IPS_RANGE_OFF_VERSION]) + ", this daemon reads 1");
  const std::uint8_t flags = h[IPS_RANGE_OFF_FLAGS];
  if (flags & ~IPS_RANGE_FLAG_ODOMETRY) return refuse("unknown flag bits");
  const std::size_t n = ips_wire_get_u16(h + IPS_RANGE_OFF_ENTRY_COUNT);
  const std::size_t entry_size = ips_wire_get_u16(h + IPS_RANGE_OFF_ENTRY_SIZE);
  if (n == 0 || n > IPS_RANGE_MAX_ENTRIES) return refuse("entry_count " + std::to_string(n));
  if (entry_size < IPS_RANGE_ENTRY_SIZE || entry_size > 256) return refuse("entry_size " + std::to_string(entry_size));
  const std::size_t body = IPS_RANGE_HEADER_SIZE + n * entry_size;
  const std::size_t want = body + (psk.empty() ? 0 : IPS_RANGE_MAC_SIZE);
  if (bytes.size() != want) {
    // The right body with a missing or surplus MAC is a key mismatch, not garbage.
    if (bytes.size() == body || bytes.size() == body + IPS_RANGE_MAC_SIZE) {
      error = RangeDatagramError::kBadKey;
      return refuse(psk.empty() ? "carries a key HMAC, the daemon has no ranging.psk" : "no key HMAC");
    }
    return refuse(std::to_string(bytes.size()) + " bytes, the counts say " + std::to_string(want));
  }
  if (!psk.empty()) {
    const subscription::Mac mac = subscription::hmac_sha256(as_bytes(psk), bytes.first(body));
    if (crypto_verify_32(mac.data(), bytes.data() + body) != 0) {  // constant time
      error = RangeDatagramError::kBadKey;
      return refuse("wrong key HMAC");
    }
  }
  RangeFiring f;
  f.tag = ips_wire_get_u32(h + IPS_RANGE_OFF_TAG);
  if (f.tag & IPS_RANGE_REF_TAG) return refuse("tag id >= 2^31");
  f.firing = ips_wire_get_u32(h + IPS_RANGE_OFF_FIRING);
  f.firing_realtime_ns = ips_wire_get_i64(h + IPS_RANGE_OFF_FIRING_REALTIME);
  if (f.firing_realtime_ns < 0) return refuse("negative firing time");
  const double odometry = ips_wire_get_f32(h + IPS_RANGE_OFF_ODOMETRY);
  const double odometry_sigma = ips_wire_get_f32(h + IPS_RANGE_OFF_ODOMETRY_SIGMA);
  if (flags & IPS_RANGE_FLAG_ODOMETRY) {
    if (!valid_range(odometry) || !valid_sigma(odometry_sigma)) return refuse("odometry out of range");
    f.odometry_m = odometry;
    f.odometry_sigma_m = odometry_sigma;
  } else if (ips_wire_get_u32(h + IPS_RANGE_OFF_ODOMETRY) != 0 ||
             ips_wire_get_u32(h + IPS_RANGE_OFF_ODOMETRY_SIGMA) != 0) {
    return refuse("odometry without the odometry flag");
  }
  std::set<std::uint32_t> seen;
  f.entries.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* e = h + IPS_RANGE_HEADER_SIZE + i * entry_size;
    const std::uint32_t raw = ips_wire_get_u32(e + IPS_RANGE_ENTRY_REFERENCE);
    RangeEntry r;
    r.reference = raw & ~IPS_RANGE_REF_TAG;
    r.reference_is_tag = (raw & IPS_RANGE_REF_TAG) != 0;
    r.range_m = ips_wire_get_f32(e + IPS_RANGE_ENTRY_RANGE);
    r.sigma_m = ips_wire_get_f32(e + IPS_RANGE_ENTRY_SIGMA);
    const std::string which = "entry " + std::to_string(i);
    if (!valid_range(r.range_m))
      return refuse(which + ": range not a number in 0.." + std::to_string(int(IPS_RANGE_MAX_RANGE_M)) + " m");
    if (!valid_sigma(r.sigma_m)) return refuse(which + ": sigma not a number >= 0");
    if (!seen.insert(raw).second) return refuse(which + ": reference repeated within one firing");
    if (r.reference_is_tag && r.reference == f.tag) return refuse(which + ": the tag ranges to itself");
    f.entries.push_back(r);
  }
  error = RangeDatagramError::kNone;
  why.clear();
  return f;
}

}  // namespace ips
