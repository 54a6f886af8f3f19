// MAVLink 2 framing checked against independent truth: the CRC catalogue's check value, a
// bit-by-bit CRC written here, CRC_EXTRA and field offsets recomputed from the message
// definitions (common.xml / minimal.xml, typed in below in declaration order) with the
// generator's rules, and hand-worked frame conversions.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ips/output/mavlink_frame.h"
#include "ips/output/mavlink_pose.h"

namespace ips {
namespace {

using namespace ips::mavlink;

// CRC-16/MCRF4XX bit by bit: reflected polynomial 0x8408, init 0xFFFF, no final xor.
std::uint16_t crc_bitwise(const std::vector<std::uint8_t>& bytes, std::uint16_t crc = 0xFFFF) {
  for (std::uint8_t b : bytes) {
    crc ^= b;
    for (int i = 0; i < 8; ++i)
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0x8408) : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

TEST(MavlinkCrc, CatalogueCheckValueAndBitwiseAgreement) {
  const std::string check = "123456789";
  const std::vector<std::uint8_t> bytes(check.begin(), check.end());
  EXPECT_EQ(crc16(bytes), 0x6F91);  // CRC-16/MCRF4XX "check" in the CRC catalogue
  EXPECT_EQ(crc_bitwise(bytes), 0x6F91);
  std::vector<std::uint8_t> noise;
  for (int i = 0; i < 300; ++i) noise.push_back(static_cast<std::uint8_t>((i * 131 + 7) ^ (i >> 3)));
  EXPECT_EQ(crc16(noise), crc_bitwise(noise));
}

// One field as the XML declares it.
struct Field {
  std::string type;  // uint8_t, uint32_t, uint64_t, float, int8_t
  std::string name;
  int array = 0;  // 0 = scalar
  bool extension = false;
};

int type_size(const std::string& t) {
  if (t == "uint64_t") return 8;
  if (t == "uint32_t" || t == "float") return 4;
  return 1;
}

// mavgen's order: base fields stable-sorted by element size, largest first; extensions after.
std::vector<Field> wire_order(std::vector<Field> fields) {
  auto ext = std::stable_partition(fields.begin(), fields.end(), [](const Field& f) { return !f.extension; });
  std::stable_sort(fields.begin(), ext,
                   [](const Field& a, const Field& b) { return type_size(a.type) > type_size(b.type); });
  return fields;
}

// mavgen's CRC_EXTRA: X.25 CRC of "NAME " and, per base field in wire order, "type name "
// plus the array length as one byte; folded to 8 bits.
std::uint8_t crc_extra(const std::string& name, const std::vector<Field>& fields) {
  std::vector<std::uint8_t> text(name.begin(), name.end());
  text.push_back(' ');
  for (const Field& f : wire_order(fields)) {
    if (f.extension) continue;
    const std::string s = f.type + " " + f.name + " ";
    text.insert(text.end(), s.begin(), s.end());
    if (f.array) text.push_back(static_cast<std::uint8_t>(f.array));
  }
  const std::uint16_t c = crc_bitwise(text);
  return static_cast<std::uint8_t>((c & 0xff) ^ (c >> 8));
}

std::size_t offset_of(const std::vector<Field>& fields, const std::string& name) {
  std::size_t off = 0;
  for (const Field& f : wire_order(fields)) {
    if (f.name == name) return off;
    off += static_cast<std::size_t>(type_size(f.type) * std::max(1, f.array));
  }
  ADD_FAILURE() << "no field " << name;
  return 0;
}

std::size_t length_of(const std::vector<Field>& fields) {
  std::size_t len = 0;
  for (const Field& f : fields) len += static_cast<std::size_t>(type_size(f.type) * std::max(1, f.array));
  return len;
}

const std::vector<Field> kHeartbeat = {{"uint8_t", "type"},          {"uint8_t", "autopilot"},
                                       {"uint8_t", "base_mode"},     {"uint32_t", "custom_mode"},
                                       {"uint8_t", "system_status"}, {"uint8_t", "mavlink_version"}};
const std::vector<Field> kVisionPositionEstimate = {{"uint64_t", "usec"},
                                                    {"float", "x"},
                                                    {"float", "y"},
                                                    {"float", "z"},
                                                    {"float", "roll"},
                                                    {"float", "pitch"},
                                                    {"float", "yaw"},
                                                    {"float", "covariance", 21, true},
                                                    {"uint8_t", "reset_counter", 0, true}};
const std::vector<Field> kOdometry = {{"uint64_t", "time_usec"},
                                      {"uint8_t", "frame_id"},
                                      {"uint8_t", "child_frame_id"},
                                      {"float", "x"},
                                      {"float", "y"},
                                      {"float", "z"},
                                      {"float", "q", 4},
                                      {"float", "vx"},
                                      {"float", "vy"},
                                      {"float", "vz"},
                                      {"float", "rollspeed"},
                                      {"float", "pitchspeed"},
                                      {"float", "yawspeed"},
                                      {"float", "pose_covariance", 21},
                                      {"float", "velocity_covariance", 21},
                                      {"uint8_t", "reset_counter", 0, true},
                                      {"uint8_t", "estimator_type", 0, true},
                                      {"int8_t", "quality", 0, true}};

TEST(MavlinkDefinitions, CrcExtraRecomputedFromTheMessageDefinitions) {
  EXPECT_EQ(crc_extra("HEARTBEAT", kHeartbeat), kCrcExtraHeartbeat);
  EXPECT_EQ(crc_extra("VISION_POSITION_ESTIMATE", kVisionPositionEstimate), kCrcExtraVisionPositionEstimate);
  EXPECT_EQ(crc_extra("ODOMETRY", kOdometry), kCrcExtraOdometry);
  // The published values (common.xml generated headers) as a second check of the recomputation.
  EXPECT_EQ(kCrcExtraHeartbeat, 50);
  EXPECT_EQ(kCrcExtraVisionPositionEstimate, 158);
  EXPECT_EQ(kCrcExtraOdometry, 91);
}

float f32_at(const std::vector<std::uint8_t>& p, std::size_t off) {
  std::uint32_t u = 0;
  for (int i = 0; i < 4; ++i) u |= static_cast<std::uint32_t>(p.at(off + static_cast<std::size_t>(i))) << (8 * i);
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

std::uint64_t u64_at(const std::vector<std::uint8_t>& p, std::size_t off) {
  std::uint64_t u = 0;
  for (int i = 0; i < 8; ++i) u |= static_cast<std::uint64_t>(p.at(off + static_cast<std::size_t>(i))) << (8 * i);
  return u;
}

TEST(MavlinkDefinitions, PayloadFieldsSitWhereTheDefinitionsPutThem) {
  VisionPositionEstimate v;
  v.usec = 0x0102030405060708ULL;
  v.x = 1.5f, v.y = -2.25f, v.z = 3.125f, v.roll = 0.1f, v.pitch = 0.2f, v.yaw = -0.3f;
  for (int i = 0; i < 21; ++i) v.covariance[static_cast<std::size_t>(i)] = static_cast<float>(i + 1);
  v.reset_counter = 42;
  const auto pv = payload(v);
  ASSERT_EQ(pv.size(), length_of(kVisionPositionEstimate));
  EXPECT_EQ(u64_at(pv, offset_of(kVisionPositionEstimate, "usec")), v.usec);
  EXPECT_EQ(f32_at(pv, offset_of(kVisionPositionEstimate, "x")), 1.5f);
  EXPECT_EQ(f32_at(pv, offset_of(kVisionPositionEstimate, "y")), -2.25f);
  EXPECT_EQ(f32_at(pv, offset_of(kVisionPositionEstimate, "z")), 3.125f);
  EXPECT_EQ(f32_at(pv, offset_of(kVisionPositionEstimate, "yaw")), -0.3f);
  EXPECT_EQ(f32_at(pv, offset_of(kVisionPositionEstimate, "covariance") + 4 * 20), 21.0f);
  EXPECT_EQ(pv[offset_of(kVisionPositionEstimate, "reset_counter")], 42);

  Odometry o;
  o.time_usec = 99;
  o.x = 1, o.y = 2, o.z = 3;
  o.q = {0.5f, 0.25f, 0.125f, 0.0625f};
  o.vx = 4, o.vy = 5, o.vz = 6, o.rollspeed = 7, o.pitchspeed = 8, o.yawspeed = 9;
  for (int i = 0; i < 21; ++i) {
    o.pose_covariance[static_cast<std::size_t>(i)] = static_cast<float>(100 + i);
    o.velocity_covariance[static_cast<std::size_t>(i)] = static_cast<float>(200 + i);
  }
  o.frame_id = 20, o.child_frame_id = 12, o.reset_counter = 3, o.estimator_type = 6, o.quality = -1;
  const auto po = payload(o);
  ASSERT_EQ(po.size(), length_of(kOdometry));
  EXPECT_EQ(u64_at(po, offset_of(kOdometry, "time_usec")), 99u);
  EXPECT_EQ(f32_at(po, offset_of(kOdometry, "z")), 3.0f);
  EXPECT_EQ(f32_at(po, offset_of(kOdometry, "q") + 12), 0.0625f);
  EXPECT_EQ(f32_at(po, offset_of(kOdometry, "yawspeed")), 9.0f);
  EXPECT_EQ(f32_at(po, offset_of(kOdometry, "pose_covariance")), 100.0f);
  EXPECT_EQ(f32_at(po, offset_of(kOdometry, "velocity_covariance") + 4 * 20), 220.0f);
  EXPECT_EQ(po[offset_of(kOdometry, "frame_id")], 20);
  EXPECT_EQ(po[offset_of(kOdometry, "child_frame_id")], 12);
  EXPECT_EQ(po[offset_of(kOdometry, "reset_counter")], 3);
  EXPECT_EQ(po[offset_of(kOdometry, "estimator_type")], 6);
  EXPECT_EQ(po[offset_of(kOdometry, "quality")], 0xFF);

  Heartbeat h;
  h.custom_mode = 0xA1B2C3D4u;
  const auto ph = payload(h);
  ASSERT_EQ(ph.size(), length_of(kHeartbeat));
  EXPECT_EQ(ph[offset_of(kHeartbeat, "custom_mode")], 0xD4);
  EXPECT_EQ(ph[offset_of(kHeartbeat, "type")], kMavTypeOnboardController);
  EXPECT_EQ(ph[offset_of(kHeartbeat, "mavlink_version")], 3);
}

TEST(MavlinkFrame, HeaderTruncationAndChecksum) {
  VisionPositionEstimate v;  // covariance 0, reset_counter 0: the extension bytes are all zero
  v.usec = 1;
  v.x = 1.0f;
  v.yaw = 0.5f;
  const auto f = frame(v, 200, 7, 197);
  // Trailing zeros dropped: the payload ends with yaw, the last non-zero field (32 bytes).
  ASSERT_EQ(f.size(), kHeaderSize + 32 + kChecksumSize);
  EXPECT_EQ(f[0], 0xFD);
  EXPECT_EQ(f[1], 32);
  EXPECT_EQ(f[2], 0);  // incompat flags
  EXPECT_EQ(f[3], 0);  // compat flags
  EXPECT_EQ(f[4], 200);
  EXPECT_EQ(f[5], 7);
  EXPECT_EQ(f[6], 197);
  EXPECT_EQ(f[7], 102);
  EXPECT_EQ(f[8], 0);
  EXPECT_EQ(f[9], 0);
  std::vector<std::uint8_t> covered(f.begin() + 1, f.end() - 2);
  covered.push_back(158);  // CRC_EXTRA
  const std::uint16_t crc = crc_bitwise(covered);
  EXPECT_EQ(f[f.size() - 2], crc & 0xff);
  EXPECT_EQ(f[f.size() - 1], crc >> 8);

  // Message id 331 takes two bytes of the 24-bit field; an all-zero payload keeps one byte.
  const auto z = frame(kMsgOdometry, kCrcExtraOdometry, 0, 1, 1, std::vector<std::uint8_t>(233, 0));
  ASSERT_EQ(z.size(), kHeaderSize + 1 + kChecksumSize);
  EXPECT_EQ(z[1], 1);
  EXPECT_EQ(z[7], 331 & 0xff);
  EXPECT_EQ(z[8], 331 >> 8);
  EXPECT_EQ(z[10], 0);
}

MarkerRecord at(double x, double y, double z, double yaw) {
  MarkerRecord m;
  m.x = x, m.y = y, m.z = z, m.yaw = yaw;
  return m;
}

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(MavlinkPose, LabXForwardMapsToFrdWithYFlippedAndZDown) {
  const MavlinkPose p = lab_to_ned(at(1, 2, 3, 0.3), 0.0, 0.0);
  EXPECT_NEAR(p.n, 1, 1e-12);
  EXPECT_NEAR(p.e, -2, 1e-12);  // lab y is to the left; FRD y to the right
  EXPECT_NEAR(p.d, -3, 1e-12);
  EXPECT_NEAR(p.heading, -0.3, 1e-12);  // counter-clockwise in the lab = negative heading
}

TEST(MavlinkPose, YawOffsetRotatesTheLabFrame) {
  // Lab x points east (heading 90 degrees): lab y (its left) points north.
  MavlinkPose p = lab_to_ned(at(1, 2, 3, 0.0), 90 * kDeg, 0.0);
  EXPECT_NEAR(p.n, 2, 1e-12);
  EXPECT_NEAR(p.e, 1, 1e-12);
  EXPECT_NEAR(p.d, -3, 1e-12);
  EXPECT_NEAR(p.heading, 90 * kDeg, 1e-12);
  p = lab_to_ned(at(0, 0, 0, 90 * kDeg), 90 * kDeg, 0.0);  // facing lab y = north
  EXPECT_NEAR(p.heading, 0.0, 1e-12);
  // 30 degrees: lab (1, 0) at heading 30 -> (cos 30, sin 30) in north/east.
  p = lab_to_ned(at(1, 0, 0, 0.0), 30 * kDeg, 0.0);
  EXPECT_NEAR(p.n, std::sqrt(3.0) / 2, 1e-12);
  EXPECT_NEAR(p.e, 0.5, 1e-12);
  // Heading wraps into (-pi, pi].
  p = lab_to_ned(at(0, 0, 0, -170 * kDeg), 30 * kDeg, 0.0);
  EXPECT_NEAR(p.heading, -160 * kDeg, 1e-12);
}

TEST(MavlinkPose, MarkerMountedSidewaysAndCovarianceRotated) {
  // Marker x points to the vehicle's left: the nose is 90 degrees clockwise of the marker's x.
  MavlinkPose p = lab_to_ned(at(0, 0, 0, 0.0), 0.0, 90 * kDeg);
  EXPECT_NEAR(p.heading, 90 * kDeg, 1e-12);  // marker x = lab x = north; nose = east
  MarkerRecord m = at(0, 0, 0, 0);
  m.covariance = {1.0, 0.5, 0.0, 4.0, 0.25, 9.0};  // xx xy xz yy yz zz
  m.vx = 1.0, m.vy = -2.0, m.vz = 0.5;
  p = lab_to_ned(m, 90 * kDeg, 0.0);  // north = lab y, east = lab x, down = -lab z
  EXPECT_NEAR(p.cov[0][0], 4.0, 1e-12);
  EXPECT_NEAR(p.cov[1][1], 1.0, 1e-12);
  EXPECT_NEAR(p.cov[2][2], 9.0, 1e-12);
  EXPECT_NEAR(p.cov[0][1], 0.5, 1e-12);
  EXPECT_NEAR(p.cov[1][0], 0.5, 1e-12);
  EXPECT_NEAR(p.cov[0][2], -0.25, 1e-12);  // cov(lab y, -lab z)
  EXPECT_NEAR(p.cov[1][2], 0.0, 1e-12);
  EXPECT_NEAR(p.vn, -2.0, 1e-12);
  EXPECT_NEAR(p.ve, 1.0, 1e-12);
  EXPECT_NEAR(p.vd, -0.5, 1e-12);
}

}  // namespace
}  // namespace ips
