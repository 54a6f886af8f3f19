// The position stream's two encodings (binary, see ips/output/wire.h; JSON lines) and their decoder.
// Encoding writes every field with explicit little-endian byte order (never a host struct).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace ips {

enum class WireFormat { kBinary, kJson };

/// "binary" | "json" -> format; throws ips::InputError naming `where` otherwise.
WireFormat parse_wire_format(const std::string& name, const std::string& where);
const char* to_string(WireFormat format);

/// One marker of a fused update. Units SI (metres, radians, m/s).
struct MarkerRecord {
  std::uint32_t id = 0;
  std::uint32_t camera_mask = 0;  ///< bit i = camera i (configuration order) contributed
  double x = 0, y = 0, z = 0;     ///< world position, metres
  double yaw = 0;                 ///< world heading, radians
  double quality = 0;             ///< sum of contributing marker areas, px^2
  double spread = 0;              ///< max distance of a camera's estimate from the fused one, m
  std::int32_t dt_us = 0;         ///< marker capture time - header capture time, microseconds
  double vx = 0, vy = 0, vz = 0;  ///< velocity, m/s (only meaningful if the datagram has_velocity)
  /// What the position came from: IPS_WIRE_SOURCE_* bits (the fusion's source_bit()). On the
  /// wire only when the datagram has_sources; a datagram without them decodes as cameras.
  std::uint16_t sources = 1;
  bool has_yaw = true;  ///< yaw measured at this time (false: the last heading held)
  /// Position covariance (the fusion's), m^2, upper triangle xx xy xz yy yz zz; all 0 = unknown.
  /// Not on the v1 wire (binary or JSON): for outputs that carry it (MAVLink, ROS 2).
  std::array<double, 6> covariance{};
};

/// One rigid body of a fused update (version 2 only; docs/bodies.md). Units SI.
struct BodyRecord {
  std::string name;                       ///< at most IPS_WIRE_BODY_NAME_SIZE - 1 bytes on the wire
  std::uint32_t camera_mask = 0;          ///< bit i = camera i (configuration order) contributed
  double x = 0, y = 0, z = 0;             ///< body origin, world, metres
  double yaw = 0;                         ///< heading of the body x axis, radians
  double qw = 1, qx = 0, qy = 0, qz = 0;  ///< orientation body -> world
  double quality = 0;                     ///< sum of contributing marker areas, px^2
  double spread = 0;                      ///< max distance of a view's body position from the fused one, m
  std::int32_t dt_us = 0;                 ///< body time - header capture time, microseconds
  bool has_yaw = false;                   ///< yaw/quaternion measured (false: position only)
  std::uint16_t id_count = 0;             ///< distinct marker ids that contributed
  std::vector<std::uint32_t> ids;         ///< the first min(id_count, IPS_WIRE_BODY_MAX_IDS), ascending
  bool has_velocity = false;              ///< vx, vy, vz measured (from the body's published positions)
  double vx = 0, vy = 0, vz = 0;          ///< world, m/s
  bool has_yaw_rate = false;              ///< yaw_rate measured
  double yaw_rate = 0;                    ///< rad/s about world z
  /// IPS_WIRE_SOURCE_* bits, as a marker record's; on the wire only when the datagram
  /// has_sources (a 120-byte record). Ranges alone: camera_mask 0, has_yaw false (held).
  std::uint16_t sources = 1;
  /// Position covariance, m^2, upper triangle xx xy xz yy yz zz (in process only: ROS 2,
  /// MAVLink); all 0 = unknown.
  std::array<double, 6> covariance{};
};

/// One datagram's content (either format). Version 1: markers only; version 2: markers and
/// bodies (ipsd sends 2 exactly when its configuration has bodies).
struct Datagram {
  std::uint16_t version = 1;
  bool has_velocity = false;
  /// Records carry sources and has_yaw (IPS_WIRE_FLAG_SOURCES; ipsd: when `ranging:` is on).
  bool has_sources = false;
  std::uint32_t sequence = 0;  ///< per-output datagram counter
  std::uint32_t update = 0;    ///< fused-update counter
  std::uint8_t part = 0;
  std::uint8_t parts = 1;
  std::int64_t capture_realtime_ns = 0;
  std::int64_t capture_monotonic_ns = 0;
  std::int64_t publish_realtime_ns = 0;
  std::vector<MarkerRecord> markers;
  std::vector<BodyRecord> bodies;  ///< version 2 only
};

/// True when `name` can be a body's name on the wire: 1..IPS_WIRE_BODY_NAME_SIZE - 1 bytes of
/// UTF-8 without NUL (the config reader checks bodies[].name with it).
bool valid_body_name(const std::string& name);

/// The name of IPS_WIRE_SOURCE_* bit `bit` in the JSON form and the web view ("camera",
/// "ranges"); nullptr for a bit this build does not know.
const char* wire_source_name(unsigned bit);
/// The names of the known bits set in a record's `sources`, lowest bit first (unknown bits
/// are skipped: a later sender's source this build cannot name).
std::vector<const char*> wire_source_names(std::uint16_t sources);

/// The message a receiver gives for a datagram of a protocol version it does not read.
std::string unsupported_version_message(unsigned version);

/// Binary form of `d` (IPS_WIRE_HEADER_SIZE + n * record size bytes, + the body section in
/// version 2). Throws std::invalid_argument for bodies in a version-1 datagram or a body name
/// longer than IPS_WIRE_BODY_NAME_SIZE - 1 bytes.
std::vector<std::uint8_t> encode_binary(const Datagram& d);
/// JSON form of `d`: one object, terminated by '\n'.
std::string encode_json(const Datagram& d);
std::vector<std::uint8_t> encode(const Datagram& d, WireFormat format);

/// Splits the markers (and bodies) of one update into datagrams of at most IPS_WIRE_MAX_DATAGRAM bytes in
/// `format`, filling part/parts (sequence is left for the sender). An update with no markers
/// gives one datagram. Throws std::length_error beyond 255 parts (never in practice: ~7000 markers).
std::vector<Datagram> split_update(const Datagram& update, WireFormat format);

/// Decodes one datagram of either format (JSON if it starts with '{'). Throws ips::InputError
/// saying what is wrong for anything malformed: short, bad magic/version, inconsistent
/// length, non-finite numbers, missing or mistyped JSON fields.
Datagram decode_datagram(std::span<const std::uint8_t> bytes);

}  // namespace ips
