// Shared by the binary and JSON halves of the datagram codec (packet_codec.cpp,
// packet_codec_json.cpp); not part of the public API (include/ips/output/packet_codec.h).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ips/output/packet_codec.h"

namespace ips::codec_detail {

/// Throws InputError("malformed datagram: why").
[[noreturn]] void malformed(const std::string& why);
/// A protocol version this build reads (1 or 2).
bool known_version(unsigned v);
/// A body name both encodings carry: valid UTF-8 (JSON), no NUL, short enough for the record.
bool valid_name(const std::string& name);
/// v, or a malformed-datagram error naming the field when it is not finite.
double finite_or_throw(double v, const char* field);
/// A marker's / body's JSON object appended to out (also sizes the JSON parts in split_update).
void append_marker_json(std::string& out, const MarkerRecord& m, bool velocity, bool sources);
void append_body_json(std::string& out, const BodyRecord& b, bool sources);
/// The JSON form's decoder (packet_codec_json.cpp).
Datagram decode_json(std::span<const std::uint8_t> bytes);

}  // namespace ips::codec_detail
