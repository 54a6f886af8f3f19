#include "ips/output/mavlink_frame.h"

#include <cstring>

namespace ips::mavlink {

std::uint16_t crc_accumulate(std::uint8_t byte, std::uint16_t crc) {
  // The MAVLink reference's byte-wise form of the reflected CCITT polynomial.
  std::uint8_t tmp = static_cast<std::uint8_t>(byte ^ static_cast<std::uint8_t>(crc & 0xff));
  tmp = static_cast<std::uint8_t>(tmp ^ static_cast<std::uint8_t>(tmp << 4));
  return static_cast<std::uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
}

std::uint16_t crc16(std::span<const std::uint8_t> bytes, std::uint16_t crc) {
  for (std::uint8_t b : bytes) crc = crc_accumulate(b, crc);
  return crc;
}

void PayloadWriter::u32(std::uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void PayloadWriter::u64(std::uint64_t v) {
  for (int i = 0; i < 8; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void PayloadWriter::f32(float v) {
  std::uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  u32(u);
}

std::vector<std::uint8_t> frame(std::uint32_t msgid, std::uint8_t crc_extra, std::uint8_t sequence,
                                std::uint8_t system_id, std::uint8_t component_id,
                                std::span<const std::uint8_t> payload) {
  // MAVLink 2 drops trailing zero bytes of the payload (the receiver zero-fills them back);
  // the first byte is always sent.
  std::size_t len = payload.size();
  while (len > 1 && payload[len - 1] == 0) --len;
  std::vector<std::uint8_t> f;
  f.reserve(kHeaderSize + len + kChecksumSize);
  f.push_back(kMagicV2);
  f.push_back(static_cast<std::uint8_t>(len));
  f.push_back(0);  // incompat_flags: not signed
  f.push_back(0);  // compat_flags
  f.push_back(sequence);
  f.push_back(system_id);
  f.push_back(component_id);
  f.push_back(static_cast<std::uint8_t>(msgid & 0xff));
  f.push_back(static_cast<std::uint8_t>((msgid >> 8) & 0xff));
  f.push_back(static_cast<std::uint8_t>((msgid >> 16) & 0xff));
  f.insert(f.end(), payload.begin(), payload.begin() + static_cast<std::ptrdiff_t>(len));
  std::uint16_t crc = crc16(std::span<const std::uint8_t>(f).subspan(1));
  crc = crc_accumulate(crc_extra, crc);
  f.push_back(static_cast<std::uint8_t>(crc & 0xff));
  f.push_back(static_cast<std::uint8_t>(crc >> 8));
  return f;
}

// Field order below = the wire order: base fields by descending type size (stable), then
// extensions as declared. Declaration order in the XML is given in each comment.

// minimal.xml HEARTBEAT: type, autopilot, base_mode, custom_mode(u32), system_status, mavlink_version.
std::vector<std::uint8_t> payload(const Heartbeat& m) {
  PayloadWriter w;
  w.u32(m.custom_mode);
  w.u8(m.type);
  w.u8(m.autopilot);
  w.u8(m.base_mode);
  w.u8(m.system_status);
  w.u8(m.mavlink_version);
  return w.bytes();
}

// common.xml VISION_POSITION_ESTIMATE: usec(u64), x, y, z, roll, pitch, yaw;
// extensions covariance[21], reset_counter(u8).
std::vector<std::uint8_t> payload(const VisionPositionEstimate& m) {
  PayloadWriter w;
  w.u64(m.usec);
  for (float v : {m.x, m.y, m.z, m.roll, m.pitch, m.yaw}) w.f32(v);
  for (float v : m.covariance) w.f32(v);
  w.u8(m.reset_counter);
  return w.bytes();
}

// common.xml ODOMETRY: time_usec(u64), frame_id(u8), child_frame_id(u8), x, y, z, q[4], vx, vy,
// vz, rollspeed, pitchspeed, yawspeed, pose_covariance[21], velocity_covariance[21];
// extensions reset_counter(u8), estimator_type(u8), quality(i8).
std::vector<std::uint8_t> payload(const Odometry& m) {
  PayloadWriter w;
  w.u64(m.time_usec);
  for (float v : {m.x, m.y, m.z}) w.f32(v);
  for (float v : m.q) w.f32(v);
  for (float v : {m.vx, m.vy, m.vz, m.rollspeed, m.pitchspeed, m.yawspeed}) w.f32(v);
  for (float v : m.pose_covariance) w.f32(v);
  for (float v : m.velocity_covariance) w.f32(v);
  w.u8(m.frame_id);
  w.u8(m.child_frame_id);
  w.u8(m.reset_counter);
  w.u8(m.estimator_type);
  w.i8(m.quality);
  return w.bytes();
}

std::vector<std::uint8_t> frame(const Heartbeat& m, std::uint8_t seq, std::uint8_t sys, std::uint8_t comp) {
  return frame(kMsgHeartbeat, kCrcExtraHeartbeat, seq, sys, comp, payload(m));
}

std::vector<std::uint8_t> frame(const VisionPositionEstimate& m, std::uint8_t seq, std::uint8_t sys,
                                std::uint8_t comp) {
  return frame(kMsgVisionPositionEstimate, kCrcExtraVisionPositionEstimate, seq, sys, comp, payload(m));
}

std::vector<std::uint8_t> frame(const Odometry& m, std::uint8_t seq, std::uint8_t sys, std::uint8_t comp) {
  return frame(kMsgOdometry, kCrcExtraOdometry, seq, sys, comp, payload(m));
}

}  // namespace ips::mavlink
