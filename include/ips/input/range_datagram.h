// The range input's datagram (byte layout in ips/input/range_wire.h): one firing of a ranging
// tag, encoded by `ips sim` and the tests, decoded by the daemon's range input.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace ips {

/// One measured range of a firing.
struct RangeEntry {
  std::uint32_t reference = 0;  ///< an anchor id, or another tag's id when reference_is_tag
  bool reference_is_tag = false;
  double range_m = 0;
  double sigma_m = 0;  ///< 0 = the anchor's configured sigma
};

/// One ranging round of one tag.
struct RangeFiring {
  std::uint32_t tag = 0;
  std::uint32_t firing = 0;             ///< the tag's firing counter
  std::int64_t firing_realtime_ns = 0;  ///< sender's CLOCK_REALTIME; 0 = not known
  std::vector<RangeEntry> entries;
  /// Distance travelled since the tag's previous firing and its sigma (metres), if measured.
  std::optional<double> odometry_m;
  double odometry_sigma_m = 0;
};

/// The datagram's bytes; with a non-empty `psk` the HMAC-SHA256 is appended. Throws
/// std::invalid_argument for a firing that no receiver would accept (no entries, too many, a
/// tag id >= 2^31, a value out of range), so a test or tool cannot send garbage by accident.
std::vector<std::uint8_t> encode_range_firing(const RangeFiring& firing, const std::string& psk);

enum class RangeDatagramError { kNone, kMalformed, kBadKey };

/// Decodes one datagram; with a non-empty `psk` it must end with a valid HMAC (compared in
/// constant time). nullopt with `error` set and `why` saying what was wrong otherwise.
std::optional<RangeFiring> decode_range_firing(std::span<const std::uint8_t> bytes, const std::string& psk,
                                               RangeDatagramError& error, std::string& why);

}  // namespace ips
