// The JSON form of a datagram (docs/stream.md): encode_json and its decoder,
// which checks every field's presence, type and range like the binary decoder.
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"
#include "packet_codec_detail.h"

namespace ips {

const char* wire_source_name(unsigned bit) {
  switch (bit) {
    case 0: return "camera";
    case 1: return "ranges";
    case 2: return "inside-out";
    default: return nullptr;  // a later source this build does not know
  }
}

std::vector<const char*> wire_source_names(std::uint16_t sources) {
  std::vector<const char*> names;
  for (unsigned bit = 0; bit < 16; ++bit)
    if (const char* name = wire_source_name(bit); name && (sources >> bit & 1u)) names.push_back(name);
  return names;
}

namespace {

void append_source_names(std::string& out, std::uint16_t sources) {
  out += ",\"sources\":[";
  bool first = true;
  for (const char* name : wire_source_names(sources)) {
    if (!first) out.push_back(',');
    out += '"';
    out += name;
    out += '"';
    first = false;
  }
  out += "]";
}

}  // namespace

namespace codec_detail {

void append_marker_json(std::string& out, const MarkerRecord& m, bool velocity, bool sources) {
  char buf[1024];
  int n = std::snprintf(buf, sizeof buf,
                        "{\"id\":%" PRIu32 ",\"cameras\":%" PRIu32
                        ",\"x\":%.5f,\"y\":%.5f,\"z\":%.5f,\"yaw\":%.5f,\"quality\":%.1f,"
                        "\"spread\":%.5f,\"dt_us\":%" PRId32,
                        m.id, m.camera_mask, m.x, m.y, m.z, m.yaw, m.quality, m.spread, m.dt_us);
  out.append(buf, static_cast<std::size_t>(n));
  if (velocity) {
    n = std::snprintf(buf, sizeof buf, ",\"vx\":%.4f,\"vy\":%.4f,\"vz\":%.4f", m.vx, m.vy, m.vz);
    out.append(buf, static_cast<std::size_t>(n));
  }
  if (sources) {
    append_source_names(out, m.sources);
    out += m.has_yaw ? ",\"has_yaw\":true" : ",\"has_yaw\":false";
  }
  out.push_back('}');
}

void append_body_json(std::string& out, const BodyRecord& b, bool sources) {
  out += "{\"name\":";
  out += nlohmann::json(b.name).dump();
  char buf[1024];
  int n = std::snprintf(
      buf, sizeof buf,
      ",\"cameras\":%" PRIu32
      ",\"x\":%.5f,\"y\":%.5f,\"z\":%.5f,\"yaw\":%.5f,\"qw\":%.6f,\"qx\":%.6f,\"qy\":%.6f,"
      "\"qz\":%.6f,\"quality\":%.1f,\"spread\":%.5f,\"dt_us\":%" PRId32 ",\"has_yaw\":%s,\"id_count\":%u,\"ids\":[",
      b.camera_mask, b.x, b.y, b.z, b.yaw, b.qw, b.qx, b.qy, b.qz, b.quality, b.spread, b.dt_us,
      b.has_yaw ? "true" : "false", static_cast<unsigned>(std::max<std::size_t>(b.id_count, b.ids.size())));
  out.append(buf, static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < b.ids.size() && i < IPS_WIRE_BODY_MAX_IDS; ++i) {
    n = std::snprintf(buf, sizeof buf, i ? ",%" PRIu32 : "%" PRIu32, b.ids[i]);
    out.append(buf, static_cast<std::size_t>(n));
  }
  out += "]";
  // Present exactly when measured (the binary record's HAS_VELOCITY / HAS_YAW_RATE flags).
  if (b.has_velocity) {
    n = std::snprintf(buf, sizeof buf, ",\"vx\":%.4f,\"vy\":%.4f,\"vz\":%.4f", b.vx, b.vy, b.vz);
    out.append(buf, static_cast<std::size_t>(n));
  }
  if (b.has_yaw_rate) {
    n = std::snprintf(buf, sizeof buf, ",\"yaw_rate\":%.4f", b.yaw_rate);
    out.append(buf, static_cast<std::size_t>(n));
  }
  if (sources) append_source_names(out, b.sources);
  out += "}";
}

namespace {

/// A record's "sources" array of names -> IPS_WIRE_SOURCE_* bits (a later source's name is skipped).
std::uint16_t source_bits(const nlohmann::json& names) {
  if (!names.is_array()) malformed("field 'sources' is not an array");
  std::uint16_t bits = 0;
  for (const auto& name : names) {
    if (!name.is_string()) malformed("a source is not a string");
    for (unsigned bit = 0; bit < 16; ++bit)
      if (const char* known = wire_source_name(bit); known && name.get<std::string>() == known)
        bits = static_cast<std::uint16_t>(bits | (1u << bit));
  }
  return bits;
}

template <typename T>
T get_integer(const nlohmann::json& obj, const char* key) {
  auto it = obj.find(key);
  if (it == obj.end()) malformed(std::string("missing field '") + key + "'");
  if (!it->is_number_integer()) malformed(std::string("field '") + key + "' is not an integer");
  if (it->is_number_unsigned()) {
    const auto v = it->get<std::uint64_t>();
    if (v > static_cast<std::uint64_t>(std::numeric_limits<T>::max()))
      malformed(std::string("field '") + key + "' out of range");
    return static_cast<T>(v);
  }
  const auto v = it->get<std::int64_t>();
  if (v < static_cast<std::int64_t>(std::numeric_limits<T>::min()) ||
      (v > 0 && static_cast<std::uint64_t>(v) > static_cast<std::uint64_t>(std::numeric_limits<T>::max())))
    malformed(std::string("field '") + key + "' out of range");
  return static_cast<T>(v);
}

double get_number(const nlohmann::json& obj, const char* key) {
  auto it = obj.find(key);
  if (it == obj.end()) malformed(std::string("missing field '") + key + "'");
  if (!it->is_number()) malformed(std::string("field '") + key + "' is not a number");
  return finite_or_throw(it->get<double>(), key);
}

}  // namespace

Datagram decode_json(std::span<const std::uint8_t> bytes) {
  const auto* begin = reinterpret_cast<const char*>(bytes.data());
  nlohmann::json j = nlohmann::json::parse(begin, begin + bytes.size(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) malformed("not valid JSON");
  if (!j.is_object()) malformed("JSON is not an object");
  auto type = j.find("type");
  if (type == j.end() || !type->is_string() || type->get<std::string>() != "ips.positions")
    malformed("JSON 'type' is not \"ips.positions\"");
  Datagram d;
  d.version = get_integer<std::uint16_t>(j, "version");
  if (!known_version(d.version)) throw InputError(unsupported_version_message(d.version));
  auto vel = j.find("velocity");
  if (vel == j.end() || !vel->is_boolean()) malformed("field 'velocity' missing or not a boolean");
  d.has_velocity = vel->get<bool>();
  // Optional (absent from the first senders): records name their sources.
  if (auto src = j.find("sources"); src != j.end()) {
    if (!src->is_boolean()) malformed("field 'sources' is not a boolean");
    d.has_sources = src->get<bool>();
  }
  d.sequence = get_integer<std::uint32_t>(j, "seq");
  d.update = get_integer<std::uint32_t>(j, "update");
  d.part = get_integer<std::uint8_t>(j, "part");
  d.parts = get_integer<std::uint8_t>(j, "parts");
  if (d.parts == 0 || d.part >= d.parts) malformed("part " + std::to_string(d.part) + " of " + std::to_string(d.parts));
  d.capture_realtime_ns = get_integer<std::int64_t>(j, "t_capture_real_ns");
  d.capture_monotonic_ns = get_integer<std::int64_t>(j, "t_capture_mono_ns");
  d.publish_realtime_ns = get_integer<std::int64_t>(j, "t_publish_real_ns");
  auto markers = j.find("markers");
  if (markers == j.end() || !markers->is_array()) malformed("field 'markers' missing or not an array");
  for (const auto& mj : *markers) {
    if (!mj.is_object()) malformed("a marker is not an object");
    MarkerRecord m;
    m.id = get_integer<std::uint32_t>(mj, "id");
    m.camera_mask = get_integer<std::uint32_t>(mj, "cameras");
    m.x = get_number(mj, "x");
    m.y = get_number(mj, "y");
    m.z = get_number(mj, "z");
    m.yaw = get_number(mj, "yaw");
    m.quality = get_number(mj, "quality");
    m.spread = get_number(mj, "spread");
    m.dt_us = get_integer<std::int32_t>(mj, "dt_us");
    if (d.has_velocity) {
      m.vx = get_number(mj, "vx");
      m.vy = get_number(mj, "vy");
      m.vz = get_number(mj, "vz");
    }
    if (d.has_sources) {
      auto names = mj.find("sources");
      if (names == mj.end()) malformed("field 'sources' missing");
      m.sources = source_bits(*names);
      auto has_yaw = mj.find("has_yaw");
      if (has_yaw == mj.end() || !has_yaw->is_boolean()) malformed("field 'has_yaw' missing or not a boolean");
      m.has_yaw = has_yaw->get<bool>();
    }
    d.markers.push_back(m);
  }
  if (d.version == IPS_WIRE_VERSION_2) {
    auto bodies = j.find("bodies");
    if (bodies == j.end() || !bodies->is_array()) malformed("field 'bodies' missing or not an array");
    for (const auto& bj : *bodies) {
      if (!bj.is_object()) malformed("a body is not an object");
      BodyRecord b;
      auto name = bj.find("name");
      if (name == bj.end() || !name->is_string()) malformed("field 'name' missing or not a string");
      b.name = name->get<std::string>();
      if (b.name.empty() || !valid_name(b.name))
        malformed("body name is empty, longer than " + std::to_string(IPS_WIRE_BODY_NAME_SIZE - 1) +
                  " bytes or has a NUL");
      b.camera_mask = get_integer<std::uint32_t>(bj, "cameras");
      b.x = get_number(bj, "x");
      b.y = get_number(bj, "y");
      b.z = get_number(bj, "z");
      b.yaw = get_number(bj, "yaw");
      b.qw = get_number(bj, "qw");
      b.qx = get_number(bj, "qx");
      b.qy = get_number(bj, "qy");
      b.qz = get_number(bj, "qz");
      b.quality = get_number(bj, "quality");
      b.spread = get_number(bj, "spread");
      b.dt_us = get_integer<std::int32_t>(bj, "dt_us");
      auto has_yaw = bj.find("has_yaw");
      if (has_yaw == bj.end() || !has_yaw->is_boolean()) malformed("field 'has_yaw' missing or not a boolean");
      b.has_yaw = has_yaw->get<bool>();
      b.id_count = get_integer<std::uint16_t>(bj, "id_count");
      auto ids = bj.find("ids");
      if (ids == bj.end() || !ids->is_array()) malformed("field 'ids' missing or not an array");
      if (ids->size() != std::min<std::size_t>(b.id_count, IPS_WIRE_BODY_MAX_IDS))
        malformed("field 'ids' does not hold min(id_count, " + std::to_string(IPS_WIRE_BODY_MAX_IDS) + ") ids");
      for (const auto& id : *ids) {
        if (!id.is_number_unsigned() || id.get<std::uint64_t>() > 0xffffffffu) malformed("a body id is not a u32");
        b.ids.push_back(static_cast<std::uint32_t>(id.get<std::uint64_t>()));
      }
      b.has_velocity = bj.contains("vx") || bj.contains("vy") || bj.contains("vz");
      if (b.has_velocity) {  // all three, or the body is malformed
        b.vx = get_number(bj, "vx");
        b.vy = get_number(bj, "vy");
        b.vz = get_number(bj, "vz");
      }
      b.has_yaw_rate = bj.contains("yaw_rate");
      if (b.has_yaw_rate) b.yaw_rate = get_number(bj, "yaw_rate");
      // Optional: the first senders with sources wrote none for bodies (cameras, then).
      if (auto names = bj.find("sources"); names != bj.end()) b.sources = source_bits(*names);
      d.bodies.push_back(std::move(b));
    }
  }
  return d;
}

}  // namespace codec_detail

std::string encode_json(const Datagram& d) {
  std::string out;
  out.reserve(256 + d.markers.size() * 160);
  char buf[384];
  const int n =
      std::snprintf(buf, sizeof buf,
                    "{\"type\":\"ips.positions\",\"version\":%u,\"seq\":%" PRIu32 ",\"update\":%" PRIu32
                    ",\"part\":%u,\"parts\":%u,\"t_capture_real_ns\":%" PRId64 ",\"t_capture_mono_ns\":%" PRId64
                    ",\"t_publish_real_ns\":%" PRId64 ",\"velocity\":%s%s,\"markers\":[",
                    static_cast<unsigned>(d.version), d.sequence, d.update, static_cast<unsigned>(d.part),
                    static_cast<unsigned>(d.parts), d.capture_realtime_ns, d.capture_monotonic_ns,
                    d.publish_realtime_ns, d.has_velocity ? "true" : "false", d.has_sources ? ",\"sources\":true" : "");
  out.append(buf, static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < d.markers.size(); ++i) {
    if (i) out.push_back(',');
    codec_detail::append_marker_json(out, d.markers[i], d.has_velocity, d.has_sources);
  }
  out.push_back(']');
  if (d.version == IPS_WIRE_VERSION_2) {
    out.append(",\"bodies\":[");
    for (std::size_t i = 0; i < d.bodies.size(); ++i) {
      if (i) out.push_back(',');
      codec_detail::append_body_json(out, d.bodies[i], d.has_sources);
    }
    out.push_back(']');
  } else if (!d.bodies.empty()) {
    throw std::invalid_argument("encode_json: bodies need protocol version 2");
  }
  out.append("}\n");
  return out;
}

}  // namespace ips
