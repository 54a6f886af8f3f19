// The position stream's decoders, fed what any host on the network can send to a listener:
// decode_datagram (binary and JSON lines; ips listen, the tests, client code) and the C
// decoder robots compile from include/ips/output/wire.h. Beyond "no fault", the two binary decoders
// must agree: a datagram the C++ decoder accepts, the C decoder accepts with the same header
// and records (marker and, version 2, body records); and what decodes re-encodes to something that decodes the same.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "ips/core/error.h"
#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"

namespace {
void check(bool ok) {
  if (!ok) std::abort();
}

bool same_ints(const ips::Datagram& a, const ips::Datagram& b) {
  if (a.version != b.version || a.has_velocity != b.has_velocity || a.sequence != b.sequence || a.update != b.update ||
      a.part != b.part || a.parts != b.parts || a.capture_realtime_ns != b.capture_realtime_ns ||
      a.capture_monotonic_ns != b.capture_monotonic_ns || a.publish_realtime_ns != b.publish_realtime_ns ||
      a.markers.size() != b.markers.size() || a.bodies.size() != b.bodies.size())
    return false;
  for (std::size_t i = 0; i < a.bodies.size(); ++i)
    if (a.bodies[i].name != b.bodies[i].name || a.bodies[i].camera_mask != b.bodies[i].camera_mask ||
        a.bodies[i].dt_us != b.bodies[i].dt_us || a.bodies[i].has_yaw != b.bodies[i].has_yaw ||
        a.bodies[i].id_count != b.bodies[i].id_count || a.bodies[i].ids != b.bodies[i].ids ||
        a.bodies[i].has_velocity != b.bodies[i].has_velocity || a.bodies[i].has_yaw_rate != b.bodies[i].has_yaw_rate)
      return false;
  for (std::size_t i = 0; i < a.markers.size(); ++i)
    if (a.markers[i].id != b.markers[i].id || a.markers[i].camera_mask != b.markers[i].camera_mask ||
        a.markers[i].dt_us != b.markers[i].dt_us)
      return false;
  return true;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  ips_wire_header h{};
  const int status = data ? ips_wire_read_header(data, size, &h) : IPS_WIRE_TOO_SHORT;
  if (status == IPS_WIRE_OK) {
    for (std::uint16_t i = 0; i < h.marker_count; ++i) {
      ips_wire_marker m{};
      ips_wire_read_marker(data, &h, i, &m);
    }
    for (std::uint16_t i = 0; i < h.body_count; ++i) {
      ips_wire_body b{};
      ips_wire_read_body(data, &h, i, &b);
    }
  }
  ips::Datagram d;
  try {
    d = ips::decode_datagram(bytes);
  } catch (const ips::InputError&) {
    return 0;
  }
  const bool json = size > 0 && data[0] == '{';
  if (!json) {
    check(status == IPS_WIRE_OK);
    check(h.version == d.version && h.sequence == d.sequence && h.update == d.update && h.part == d.part &&
          h.parts == d.parts && h.marker_count == d.markers.size() && h.capture_realtime_ns == d.capture_realtime_ns &&
          h.capture_monotonic_ns == d.capture_monotonic_ns && h.publish_realtime_ns == d.publish_realtime_ns &&
          ((h.flags & IPS_WIRE_FLAG_VELOCITY) != 0) == d.has_velocity);
    for (std::uint16_t i = 0; i < h.marker_count; ++i) {
      ips_wire_marker m{};
      ips_wire_read_marker(data, &h, i, &m);
      const ips::MarkerRecord& r = d.markers[i];
      check(m.id == r.id && m.camera_mask == r.camera_mask && m.dt_us == r.dt_us && double(m.x) == r.x &&
            double(m.y) == r.y && double(m.z) == r.z && double(m.yaw) == r.yaw && double(m.vx) == r.vx);
    }
    check(h.body_count == d.bodies.size());
    for (std::uint16_t i = 0; i < h.body_count; ++i) {
      ips_wire_body b{};
      ips_wire_read_body(data, &h, i, &b);
      const ips::BodyRecord& r = d.bodies[i];
      check(r.name == b.name && b.camera_mask == r.camera_mask && b.dt_us == r.dt_us && double(b.x) == r.x &&
            double(b.qw) == r.qw && double(b.qz) == r.qz && b.id_count == r.id_count &&
            ((b.flags & IPS_WIRE_BODY_HAS_YAW) != 0) == r.has_yaw &&
            ((b.flags & IPS_WIRE_BODY_HAS_VELOCITY) != 0) == r.has_velocity && double(b.vx) == r.vx &&
            double(b.vz) == r.vz && ((b.flags & IPS_WIRE_BODY_HAS_YAW_RATE) != 0) == r.has_yaw_rate &&
            double(b.yaw_rate) == r.yaw_rate);
      for (std::size_t k = 0; k < r.ids.size(); ++k) check(b.ids[k] == r.ids[k]);
    }
  }
  // What the decoder accepted, the encoders can write, and it decodes the same.
  for (const ips::WireFormat f : {ips::WireFormat::kBinary, ips::WireFormat::kJson}) {
    const auto again = ips::encode(d, f);
    ips::Datagram e;
    try {
      e = ips::decode_datagram(again);
    } catch (const ips::InputError&) {
      std::abort();  // our own encoding of an accepted datagram refused
    }
    check(same_ints(d, e));
  }
  return 0;
}
