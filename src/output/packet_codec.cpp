#include "ips/output/packet_codec.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/output/wire.h"
#include "packet_codec_detail.h"

namespace ips {

WireFormat parse_wire_format(const std::string& name, const std::string& where) {
  if (name == "binary") return WireFormat::kBinary;
  if (name == "json") return WireFormat::kJson;
  throw InputError(where + ": unknown format '" + name + "' (binary|json)");
}

const char* to_string(WireFormat format) { return format == WireFormat::kBinary ? "binary" : "json"; }

namespace codec_detail {

void malformed(const std::string& why) { throw InputError("malformed datagram: " + why); }

bool known_version(unsigned v) { return v == IPS_WIRE_VERSION || v == IPS_WIRE_VERSION_2; }

// A body name must survive both encodings: valid UTF-8 (JSON) and short enough for the record.
bool valid_name(const std::string& name) {
  if (name.size() >= IPS_WIRE_BODY_NAME_SIZE || name.find('\0') != std::string::npos) return false;
  try {
    (void)nlohmann::json(name).dump();
  } catch (const nlohmann::json::exception&) {
    return false;
  }
  return true;
}

double finite_or_throw(double v, const char* field) {
  if (!std::isfinite(v)) malformed(std::string("field '") + field + "' is not a finite number");
  return v;
}

}  // namespace codec_detail

using codec_detail::append_body_json;
using codec_detail::append_marker_json;
using codec_detail::decode_json;
using codec_detail::finite_or_throw;
using codec_detail::known_version;
using codec_detail::malformed;
using codec_detail::valid_name;

namespace {

std::size_t record_size(const Datagram& d) {
  if (d.has_sources) return IPS_WIRE_RECORD_SIZE_SOURCES;
  return d.has_velocity ? IPS_WIRE_RECORD_SIZE_VELOCITY : IPS_WIRE_RECORD_SIZE;
}

std::size_t body_record_size(const Datagram& d) {
  return d.has_sources ? IPS_WIRE_BODY_RECORD_SIZE_SOURCES : IPS_WIRE_BODY_RECORD_SIZE;
}

Datagram decode_binary(std::span<const std::uint8_t> bytes) {
  ips_wire_header h{};
  const int status = ips_wire_read_header(bytes.data(), bytes.size(), &h);
  switch (status) {
    case IPS_WIRE_OK: break;
    case IPS_WIRE_TOO_SHORT: malformed(std::to_string(bytes.size()) + " bytes, shorter than a header");
    case IPS_WIRE_BAD_MAGIC: malformed("bad magic");
    case IPS_WIRE_BAD_VERSION: throw InputError(unsupported_version_message(h.version));
    case IPS_WIRE_BAD_BODY_RECORD_SIZE:
      malformed("body_record_size " + std::to_string(h.body_record_size) + " too small");
    case IPS_WIRE_BAD_RECORD_SIZE: malformed("record_size " + std::to_string(h.record_size) + " too small");
    case IPS_WIRE_BAD_LENGTH:
      malformed("length " + std::to_string(bytes.size()) + " does not match " + std::to_string(h.marker_count) +
                " records of " + std::to_string(h.record_size) + " bytes" +
                (h.version == IPS_WIRE_VERSION_2 ? " + the body section" : ""));
    case IPS_WIRE_BAD_PARTS: malformed("part " + std::to_string(h.part) + " of " + std::to_string(h.parts));
    default: malformed("unknown header error");
  }
  Datagram d;
  d.version = h.version;
  d.has_velocity = (h.flags & IPS_WIRE_FLAG_VELOCITY) != 0;
  d.has_sources = (h.flags & IPS_WIRE_FLAG_SOURCES) != 0;
  d.sequence = h.sequence;
  d.update = h.update;
  d.part = h.part;
  d.parts = h.parts;
  d.capture_realtime_ns = h.capture_realtime_ns;
  d.capture_monotonic_ns = h.capture_monotonic_ns;
  d.publish_realtime_ns = h.publish_realtime_ns;
  d.markers.reserve(h.marker_count);
  for (std::uint16_t i = 0; i < h.marker_count; ++i) {
    ips_wire_marker w{};
    ips_wire_read_marker(bytes.data(), &h, i, &w);
    MarkerRecord m;
    m.id = w.id;
    m.camera_mask = w.camera_mask;
    m.x = finite_or_throw(w.x, "x");
    m.y = finite_or_throw(w.y, "y");
    m.z = finite_or_throw(w.z, "z");
    m.yaw = finite_or_throw(w.yaw, "yaw");
    m.quality = finite_or_throw(w.quality, "quality");
    m.spread = finite_or_throw(w.spread, "spread");
    m.dt_us = w.dt_us;
    m.vx = finite_or_throw(w.vx, "vx");
    m.vy = finite_or_throw(w.vy, "vy");
    m.vz = finite_or_throw(w.vz, "vz");
    m.sources = w.sources;
    m.has_yaw = (w.marker_flags & IPS_WIRE_MARKER_HAS_YAW) != 0;
    d.markers.push_back(m);
  }
  d.bodies.reserve(h.body_count);
  for (std::uint16_t i = 0; i < h.body_count; ++i) {
    ips_wire_body w{};
    ips_wire_read_body(bytes.data(), &h, i, &w);
    BodyRecord b;
    b.name.assign(w.name, ::strnlen(w.name, sizeof w.name));
    if (b.name.empty() || !valid_name(b.name)) malformed("body name is empty or not UTF-8");
    b.camera_mask = w.camera_mask;
    b.x = finite_or_throw(w.x, "x");
    b.y = finite_or_throw(w.y, "y");
    b.z = finite_or_throw(w.z, "z");
    b.yaw = finite_or_throw(w.yaw, "yaw");
    b.qw = finite_or_throw(w.qw, "qw");
    b.qx = finite_or_throw(w.qx, "qx");
    b.qy = finite_or_throw(w.qy, "qy");
    b.qz = finite_or_throw(w.qz, "qz");
    b.quality = finite_or_throw(w.quality, "quality");
    b.spread = finite_or_throw(w.spread, "spread");
    b.dt_us = w.dt_us;
    b.has_yaw = (w.flags & IPS_WIRE_BODY_HAS_YAW) != 0;
    b.has_velocity = (w.flags & IPS_WIRE_BODY_HAS_VELOCITY) != 0;
    b.vx = finite_or_throw(w.vx, "vx");
    b.vy = finite_or_throw(w.vy, "vy");
    b.vz = finite_or_throw(w.vz, "vz");
    b.has_yaw_rate = (w.flags & IPS_WIRE_BODY_HAS_YAW_RATE) != 0;
    b.yaw_rate = finite_or_throw(w.yaw_rate, "yaw_rate");
    b.sources = w.sources;
    b.id_count = w.id_count;
    b.ids.assign(w.ids, w.ids + std::min<unsigned>(w.id_count, IPS_WIRE_BODY_MAX_IDS));
    d.bodies.push_back(std::move(b));
  }
  return d;
}

}  // namespace

bool valid_body_name(const std::string& name) { return !name.empty() && valid_name(name); }

std::string unsupported_version_message(unsigned version) {
  return "ipsd stream version " + std::to_string(version) + (version == IPS_WIRE_VERSION_2 ? " (rigid bodies)" : "") +
         ": this client reads versions 1 and 2; update it";
}

std::vector<std::uint8_t> encode_binary(const Datagram& d) {
  if (d.markers.size() > 0xffff) throw std::length_error("encode_binary: more than 65535 markers");
  if (d.bodies.size() > 0xffff) throw std::length_error("encode_binary: more than 65535 bodies");
  const bool v2 = d.version == IPS_WIRE_VERSION_2;
  if (!v2 && !d.bodies.empty()) throw std::invalid_argument("encode_binary: bodies need protocol version 2");
  for (const BodyRecord& b : d.bodies)
    if (!valid_name(b.name))
      throw std::invalid_argument("encode_binary: body name '" + b.name + "' does not fit the wire");
  const std::size_t rs = record_size(d);
  const std::size_t bs = body_record_size(d);
  const std::size_t markers_end = IPS_WIRE_HEADER_SIZE + d.markers.size() * rs;
  std::vector<std::uint8_t> out(markers_end + (v2 ? IPS_WIRE_BODY_SECTION_SIZE + d.bodies.size() * bs : 0), 0);
  std::uint8_t* p = out.data();
  if (p == nullptr) throw std::logic_error("encode_binary: allocation");  // never: size >= 48
  p[0] = IPS_WIRE_MAGIC_0;
  p[1] = IPS_WIRE_MAGIC_1;
  p[2] = IPS_WIRE_MAGIC_2;
  p[3] = IPS_WIRE_MAGIC_3;
  ips_wire_put_u16(p + IPS_WIRE_OFF_VERSION, d.version);
  ips_wire_put_u16(p + IPS_WIRE_OFF_FLAGS, static_cast<std::uint16_t>((d.has_velocity ? IPS_WIRE_FLAG_VELOCITY : 0u) |
                                                                      (d.has_sources ? IPS_WIRE_FLAG_SOURCES : 0u)));
  ips_wire_put_u32(p + IPS_WIRE_OFF_SEQUENCE, d.sequence);
  ips_wire_put_u16(p + IPS_WIRE_OFF_MARKER_COUNT, static_cast<std::uint16_t>(d.markers.size()));
  ips_wire_put_u16(p + IPS_WIRE_OFF_RECORD_SIZE, static_cast<std::uint16_t>(rs));
  p[IPS_WIRE_OFF_PART] = d.part;
  p[IPS_WIRE_OFF_PARTS] = d.parts;
  ips_wire_put_u32(p + IPS_WIRE_OFF_UPDATE, d.update);
  ips_wire_put_i64(p + IPS_WIRE_OFF_CAPTURE_REALTIME, d.capture_realtime_ns);
  ips_wire_put_i64(p + IPS_WIRE_OFF_CAPTURE_MONOTONIC, d.capture_monotonic_ns);
  ips_wire_put_i64(p + IPS_WIRE_OFF_PUBLISH_REALTIME, d.publish_realtime_ns);
  for (std::size_t i = 0; i < d.markers.size(); ++i) {
    const MarkerRecord& m = d.markers[i];
    std::uint8_t* r = p + IPS_WIRE_HEADER_SIZE + i * rs;
    ips_wire_put_u32(r + IPS_WIRE_REC_ID, m.id);
    ips_wire_put_u32(r + IPS_WIRE_REC_CAMERA_MASK, m.camera_mask);
    ips_wire_put_f32(r + IPS_WIRE_REC_X, static_cast<float>(m.x));
    ips_wire_put_f32(r + IPS_WIRE_REC_Y, static_cast<float>(m.y));
    ips_wire_put_f32(r + IPS_WIRE_REC_Z, static_cast<float>(m.z));
    ips_wire_put_f32(r + IPS_WIRE_REC_YAW, static_cast<float>(m.yaw));
    ips_wire_put_f32(r + IPS_WIRE_REC_QUALITY, static_cast<float>(m.quality));
    ips_wire_put_f32(r + IPS_WIRE_REC_SPREAD, static_cast<float>(m.spread));
    ips_wire_put_i32(r + IPS_WIRE_REC_DT_US, m.dt_us);
    if (d.has_velocity) {
      ips_wire_put_f32(r + IPS_WIRE_REC_VX, static_cast<float>(m.vx));
      ips_wire_put_f32(r + IPS_WIRE_REC_VY, static_cast<float>(m.vy));
      ips_wire_put_f32(r + IPS_WIRE_REC_VZ, static_cast<float>(m.vz));
    }
    if (d.has_sources) {
      ips_wire_put_u16(r + IPS_WIRE_REC_SOURCES, m.sources);
      ips_wire_put_u16(r + IPS_WIRE_REC_MARKER_FLAGS, m.has_yaw ? IPS_WIRE_MARKER_HAS_YAW : 0u);
    }
  }
  if (v2) {
    std::uint8_t* sec = p + markers_end;
    ips_wire_put_u16(sec, static_cast<std::uint16_t>(d.bodies.size()));
    ips_wire_put_u16(sec + 2, static_cast<std::uint16_t>(bs));
    for (std::size_t i = 0; i < d.bodies.size(); ++i) {
      const BodyRecord& b = d.bodies[i];
      std::uint8_t* r = sec + IPS_WIRE_BODY_SECTION_SIZE + i * bs;
      std::memcpy(r + IPS_WIRE_BODY_NAME, b.name.data(), b.name.size());  // the rest stays NUL
      ips_wire_put_u32(r + IPS_WIRE_BODY_CAMERA_MASK, b.camera_mask);
      ips_wire_put_f32(r + IPS_WIRE_BODY_X, static_cast<float>(b.x));
      ips_wire_put_f32(r + IPS_WIRE_BODY_Y, static_cast<float>(b.y));
      ips_wire_put_f32(r + IPS_WIRE_BODY_Z, static_cast<float>(b.z));
      ips_wire_put_f32(r + IPS_WIRE_BODY_YAW, static_cast<float>(b.yaw));
      ips_wire_put_f32(r + IPS_WIRE_BODY_QW, static_cast<float>(b.qw));
      ips_wire_put_f32(r + IPS_WIRE_BODY_QX, static_cast<float>(b.qx));
      ips_wire_put_f32(r + IPS_WIRE_BODY_QY, static_cast<float>(b.qy));
      ips_wire_put_f32(r + IPS_WIRE_BODY_QZ, static_cast<float>(b.qz));
      ips_wire_put_f32(r + IPS_WIRE_BODY_QUALITY, static_cast<float>(b.quality));
      ips_wire_put_f32(r + IPS_WIRE_BODY_SPREAD, static_cast<float>(b.spread));
      ips_wire_put_i32(r + IPS_WIRE_BODY_DT_US, b.dt_us);
      ips_wire_put_u16(r + IPS_WIRE_BODY_FLAGS,
                       static_cast<std::uint16_t>((b.has_yaw ? IPS_WIRE_BODY_HAS_YAW : 0u) |
                                                  (b.has_velocity ? IPS_WIRE_BODY_HAS_VELOCITY : 0u) |
                                                  (b.has_yaw_rate ? IPS_WIRE_BODY_HAS_YAW_RATE : 0u)));
      if (b.has_velocity) {
        ips_wire_put_f32(r + IPS_WIRE_BODY_VX, static_cast<float>(b.vx));
        ips_wire_put_f32(r + IPS_WIRE_BODY_VY, static_cast<float>(b.vy));
        ips_wire_put_f32(r + IPS_WIRE_BODY_VZ, static_cast<float>(b.vz));
      }
      if (b.has_yaw_rate) ips_wire_put_f32(r + IPS_WIRE_BODY_YAW_RATE, static_cast<float>(b.yaw_rate));
      if (d.has_sources) ips_wire_put_u16(r + IPS_WIRE_BODY_SOURCES, b.sources);
      const std::size_t count = std::min<std::size_t>(std::max<std::size_t>(b.id_count, b.ids.size()), 0xffff);
      ips_wire_put_u16(r + IPS_WIRE_BODY_ID_COUNT, static_cast<std::uint16_t>(count));
      for (std::size_t k = 0; k < b.ids.size() && k < IPS_WIRE_BODY_MAX_IDS; ++k)
        ips_wire_put_u32(r + IPS_WIRE_BODY_IDS + 4 * k, b.ids[k]);
    }
  }
  return out;
}

std::vector<std::uint8_t> encode(const Datagram& d, WireFormat format) {
  if (format == WireFormat::kBinary) return encode_binary(d);
  const std::string s = encode_json(d);
  return {s.begin(), s.end()};
}

std::vector<Datagram> split_update(const Datagram& update, WireFormat format) {
  std::vector<Datagram> parts;
  Datagram shell = update;
  shell.markers.clear();
  shell.bodies.clear();
  // Worst-case header: every counter at its widest, so the final numbers can only shrink it.
  Datagram widest = shell;
  widest.sequence = 0xffffffffu;
  widest.update = 0xffffffffu;
  widest.part = widest.parts = 255;
  const bool v2 = update.version == IPS_WIRE_VERSION_2;
  const std::size_t header_bytes = format == WireFormat::kBinary
                                       ? IPS_WIRE_HEADER_SIZE + (v2 ? IPS_WIRE_BODY_SECTION_SIZE : 0)
                                       : encode_json(widest).size();
  const std::size_t budget = IPS_WIRE_MAX_DATAGRAM;

  Datagram current = shell;
  std::size_t used = header_bytes;
  for (const MarkerRecord& m : update.markers) {
    std::size_t bytes;
    if (format == WireFormat::kBinary) {
      bytes = record_size(update);
    } else {
      std::string s;
      append_marker_json(s, m, update.has_velocity, update.has_sources);
      bytes = s.size() + 1;  // the separating comma
    }
    if (used + bytes > budget && !current.markers.empty()) {
      parts.push_back(std::move(current));
      current = shell;
      used = header_bytes;
    }
    current.markers.push_back(m);
    used += bytes;
  }
  for (const BodyRecord& b : update.bodies) {
    std::size_t bytes = body_record_size(update);
    if (format == WireFormat::kJson) {
      std::string s;
      append_body_json(s, b, update.has_sources);
      bytes = s.size() + 1;
    }
    if (used + bytes > budget && (!current.markers.empty() || !current.bodies.empty())) {
      parts.push_back(std::move(current));
      current = shell;
      used = header_bytes;
    }
    current.bodies.push_back(b);
    used += bytes;
  }
  parts.push_back(std::move(current));
  if (parts.size() > 255) throw std::length_error("split_update: more than 255 datagrams");
  for (std::size_t i = 0; i < parts.size(); ++i) {
    parts[i].part = static_cast<std::uint8_t>(i);
    parts[i].parts = static_cast<std::uint8_t>(parts.size());
  }
  return parts;
}

Datagram decode_datagram(std::span<const std::uint8_t> bytes) {
  if (bytes.empty()) malformed("empty");
  if (bytes[0] == '{') return decode_json(bytes);
  return decode_binary(bytes);
}

}  // namespace ips
