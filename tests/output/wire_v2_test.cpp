// Protocol version 2 (rigid bodies, include/ips/output/wire.h): the encoder writes the bytes the
// layout documents (checked against bytes written out by hand), the C helpers and the C++
// decoder read them alike, and receivers refuse versions they do not read with a clear message.
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "ips/core/error.h"
#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"

namespace ips {
namespace {

Datagram one_body() {
  Datagram d;
  d.version = 2;
  d.sequence = 41;
  d.update = 7;
  d.capture_realtime_ns = 0x0102030405060708;
  d.capture_monotonic_ns = 55;
  BodyRecord b;
  b.name = "cube";
  b.camera_mask = 5;
  b.x = 1.5;
  b.y = -0.25;
  b.z = 0;
  b.yaw = 0.5;
  b.qw = b.qx = b.qy = b.qz = 0.5;
  b.quality = 800;
  b.spread = 0.125;
  b.dt_us = -2;
  b.has_yaw = true;
  b.id_count = 2;
  b.ids = {7, 300};
  b.has_velocity = true;
  b.vx = 0.5;
  b.vy = -1.0;
  b.has_yaw_rate = true;
  b.yaw_rate = 0.25;
  d.bodies = {b};
  return d;
}

// Written out by hand from the layout in wire.h (floats: IEEE-754 single, little-endian).
const std::vector<std::uint8_t> kOneBody = {
    'I',  'P',  'S',  'D',  2,    0, 0, 0,                                      // magic, version 2, flags 0
    41,   0,    0,    0,                                                        // sequence
    0,    0,    36,   0,                                                        // marker_count 0, record_size 36
    0,    1,    0,    0,                                                        // part 0 of 1, reserved
    7,    0,    0,    0,                                                        // update
    8,    7,    6,    5,    4,    3, 2, 1,                                      // capture_realtime_ns
    55,   0,    0,    0,    0,    0, 0, 0,                                      // capture_monotonic_ns
    0,    0,    0,    0,    0,    0, 0, 0,                                      // publish_realtime_ns
    1,    0,    116,  0,                                                        // body section: 1 body of 116 bytes
    'c',  'u',  'b',  'e',  0,    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,              // name, NUL-padded to 32
    0,    0,    0,    0,    0,    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 5, 0, 0, 0,  // camera_mask
    0,    0,    0xc0, 0x3f,                                                     // x 1.5
    0,    0,    0x80, 0xbe,                                                     // y -0.25
    0,    0,    0,    0,                                                        // z 0
    0,    0,    0,    0x3f,                                                     // yaw 0.5
    0,    0,    0,    0x3f,                                                     // qw 0.5
    0,    0,    0,    0x3f,                                                     // qx
    0,    0,    0,    0x3f,                                                     // qy
    0,    0,    0,    0x3f,                                                     // qz
    0,    0,    0x48, 0x44,                                                     // quality 800
    0,    0,    0,    0x3e,                                                     // spread 0.125
    0xfe, 0xff, 0xff, 0xff,                                                     // dt_us -2
    7,    0,                                                        // body_flags: has yaw, velocity, yaw rate
    2,    0,                                                        // id_count
    7,    0,    0,    0,    0x2c, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,  // ids 7, 300, 0, 0
    0,    0,    0,    0x3f,                                         // vx 0.5
    0,    0,    0x80, 0xbf,                                         // vy -1
    0,    0,    0,    0,                                            // vz 0
    0,    0,    0x80, 0x3e,                                         // yaw_rate 0.25
};

TEST(WireV2, EncoderWritesTheDocumentedBytes) {
  ASSERT_EQ(kOneBody.size(), 168u);
  EXPECT_EQ(encode_binary(one_body()), kOneBody);
}

TEST(WireV2, CHelpersAndCppDecoderReadTheHandWrittenBytes) {
  ips_wire_header h{};
  ASSERT_EQ(ips_wire_read_header(kOneBody.data(), kOneBody.size(), &h), IPS_WIRE_OK);
  EXPECT_EQ(h.version, 2);
  EXPECT_EQ(h.marker_count, 0);
  ASSERT_EQ(h.body_count, 1);
  EXPECT_EQ(h.body_record_size, 116);
  ips_wire_body b{};
  ips_wire_read_body(kOneBody.data(), &h, 0, &b);
  EXPECT_STREQ(b.name, "cube");
  EXPECT_EQ(b.camera_mask, 5u);
  EXPECT_EQ(b.x, 1.5f);
  EXPECT_EQ(b.y, -0.25f);
  EXPECT_EQ(b.qz, 0.5f);
  EXPECT_EQ(b.quality, 800.0f);
  EXPECT_EQ(b.dt_us, -2);
  EXPECT_EQ(b.flags, IPS_WIRE_BODY_HAS_YAW | IPS_WIRE_BODY_HAS_VELOCITY | IPS_WIRE_BODY_HAS_YAW_RATE);
  EXPECT_EQ(b.id_count, 2);
  EXPECT_EQ(b.ids[1], 300u);
  EXPECT_EQ(b.vx, 0.5f);
  EXPECT_EQ(b.vy, -1.0f);
  EXPECT_EQ(b.vz, 0.0f);
  EXPECT_EQ(b.yaw_rate, 0.25f);

  const Datagram d = decode_datagram(kOneBody);
  EXPECT_EQ(d.version, 2);
  EXPECT_EQ(d.sequence, 41u);
  EXPECT_EQ(d.capture_realtime_ns, 0x0102030405060708);
  ASSERT_EQ(d.bodies.size(), 1u);
  const BodyRecord& r = d.bodies[0];
  EXPECT_EQ(r.name, "cube");
  EXPECT_EQ(r.x, 1.5);
  EXPECT_EQ(r.spread, 0.125);
  EXPECT_TRUE(r.has_yaw);
  EXPECT_EQ(r.ids, (std::vector<std::uint32_t>{7, 300}));
  EXPECT_TRUE(r.has_velocity);
  EXPECT_EQ(r.vx, 0.5);
  EXPECT_EQ(r.vy, -1.0);
  EXPECT_TRUE(r.has_yaw_rate);
  EXPECT_EQ(r.yaw_rate, 0.25);
}

TEST(WireV2, RecordsOfTheFirstBodySendersHaveNoVelocity) {
  // The first ipsd with bodies sent 100-byte records (no velocity fields): both readers accept
  // them and report no velocity, even if a flag bit says otherwise.
  std::vector<std::uint8_t> old(kOneBody.begin(), kOneBody.end() - 16);
  old[48 + 2] = 100;
  ips_wire_header h{};
  ASSERT_EQ(ips_wire_read_header(old.data(), old.size(), &h), IPS_WIRE_OK);
  ips_wire_body b{};
  b.vx = 9.0f;
  ips_wire_read_body(old.data(), &h, 0, &b);
  EXPECT_EQ(b.flags, IPS_WIRE_BODY_HAS_YAW);
  EXPECT_EQ(b.vx, 0.0f);
  EXPECT_EQ(b.yaw_rate, 0.0f);
  const Datagram d = decode_datagram(old);
  ASSERT_EQ(d.bodies.size(), 1u);
  EXPECT_TRUE(d.bodies[0].has_yaw);
  EXPECT_FALSE(d.bodies[0].has_velocity);
  EXPECT_FALSE(d.bodies[0].has_yaw_rate);
  EXPECT_EQ(d.bodies[0].x, 1.5);
  // A body without a measured velocity: zeros on the wire, flags clear.
  Datagram still = one_body();
  still.bodies[0].has_velocity = still.bodies[0].has_yaw_rate = false;
  const auto bytes = encode_binary(still);
  EXPECT_EQ(bytes[48 + 4 + 80], IPS_WIRE_BODY_HAS_YAW);
  EXPECT_EQ(std::vector<std::uint8_t>(bytes.end() - 16, bytes.end()), std::vector<std::uint8_t>(16, 0));
  EXPECT_FALSE(decode_datagram(bytes).bodies[0].has_velocity);
}

TEST(WireV2, MarkersAndBodiesTogetherAndLongerBodyRecordsAreStepped) {
  Datagram d = one_body();
  MarkerRecord m;
  m.id = 12;
  m.x = 2;
  d.markers = {m, m};
  d.bodies.push_back(d.bodies[0]);
  d.bodies[1].name = "robot two";
  d.bodies[1].has_yaw = false;
  auto bytes = encode_binary(d);
  ASSERT_EQ(bytes.size(), 48u + 2 * 36 + 4 + 2 * 116);
  // A later minor revision appends 8 bytes to every body record: an old v2 receiver skips them.
  std::vector<std::uint8_t> longer(bytes.begin(), bytes.begin() + 48 + 72 + 4);
  longer[48 + 72 + 2] = 124;
  for (int i = 0; i < 2; ++i) {
    longer.insert(longer.end(), bytes.begin() + 48 + 72 + 4 + 116 * i, bytes.begin() + 48 + 72 + 4 + 116 * (i + 1));
    longer.insert(longer.end(), 8, 0xab);
  }
  for (const auto* b : {&bytes, &longer}) {
    const Datagram e = decode_datagram(*b);
    ASSERT_EQ(e.markers.size(), 2u);
    ASSERT_EQ(e.bodies.size(), 2u);
    EXPECT_EQ(e.markers[1].x, 2);
    EXPECT_EQ(e.bodies[1].name, "robot two");
    EXPECT_FALSE(e.bodies[1].has_yaw);
    EXPECT_EQ(e.bodies[1].vy, -1.0);
    ips_wire_header h{};
    ASSERT_EQ(ips_wire_read_header(b->data(), b->size(), &h), IPS_WIRE_OK);
    ips_wire_body w{};
    ips_wire_read_body(b->data(), &h, 1, &w);
    EXPECT_STREQ(w.name, "robot two");
  }
  // Too short a body record, a wrong length: refused by both.
  auto bad = bytes;
  bad[48 + 72 + 2] = 99;
  ips_wire_header h{};
  EXPECT_EQ(ips_wire_read_header(bad.data(), bad.size(), &h), IPS_WIRE_BAD_BODY_RECORD_SIZE);
  EXPECT_THROW(decode_datagram(bad), InputError);
  bad = bytes;
  bad.pop_back();
  EXPECT_EQ(ips_wire_read_header(bad.data(), bad.size(), &h), IPS_WIRE_BAD_LENGTH);
  EXPECT_THROW(decode_datagram(bad), InputError);
}

TEST(WireV2, JsonCarriesTheBodies) {
  const Datagram d = one_body();
  const std::string j = encode_json(d);
  EXPECT_NE(j.find("\"bodies\":[{\"name\":\"cube\""), std::string::npos) << j;
  const Datagram e = decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(j.data()), j.size()));
  ASSERT_EQ(e.bodies.size(), 1u);
  EXPECT_EQ(e.bodies[0].name, "cube");
  EXPECT_DOUBLE_EQ(e.bodies[0].y, -0.25);
  EXPECT_EQ(e.bodies[0].ids, (std::vector<std::uint32_t>{7, 300}));
  EXPECT_TRUE(e.bodies[0].has_velocity);
  EXPECT_DOUBLE_EQ(e.bodies[0].vy, -1.0);
  EXPECT_DOUBLE_EQ(e.bodies[0].yaw_rate, 0.25);
  // Without a measured velocity the keys are absent, and a body with only some of vx/vy/vz is
  // malformed.
  Datagram still = one_body();
  still.bodies[0].has_velocity = still.bodies[0].has_yaw_rate = false;
  const std::string js = encode_json(still);
  EXPECT_EQ(js.find("\"vx\""), std::string::npos) << js;
  EXPECT_EQ(js.find("yaw_rate"), std::string::npos) << js;
  EXPECT_FALSE(
      decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(js.data()), js.size())).bodies[0].has_velocity);
  std::string partial = j;
  const auto vy = partial.find(",\"vy\"");
  partial.erase(vy, partial.find(",\"vz\"") - vy);  // valid JSON, vx and vz without vy
  EXPECT_THROW(decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(partial.data()), partial.size())),
               InputError)
      << partial;
  // Version 1 JSON has no bodies key.
  Datagram v1;
  EXPECT_EQ(encode_json(v1).find("bodies"), std::string::npos);
}

TEST(WireV2, UnknownVersionsAreRefusedWithAClearMessage) {
  auto bytes = kOneBody;
  bytes[4] = 3;
  ips_wire_header h{};
  EXPECT_EQ(ips_wire_read_header(bytes.data(), bytes.size(), &h), IPS_WIRE_BAD_VERSION);
  try {
    decode_datagram(bytes);
    FAIL() << "version 3 accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "ipsd stream version 3: this client reads versions 1 and 2; update it");
  }
  EXPECT_EQ(unsupported_version_message(2),
            "ipsd stream version 2 (rigid bodies): this client reads versions 1 and 2; update it");
}

TEST(WireV2, EncoderRefusesWhatTheWireCannotCarry) {
  Datagram d = one_body();
  d.version = 1;
  EXPECT_THROW(encode_binary(d), std::invalid_argument);
  EXPECT_THROW(encode_json(d), std::invalid_argument);
  d = one_body();
  d.bodies[0].name = std::string(32, 'x');  // 31 bytes is the most
  EXPECT_THROW(encode_binary(d), std::invalid_argument);
  d.bodies[0].name = std::string(31, 'x');
  EXPECT_EQ(decode_datagram(encode_binary(d)).bodies[0].name, d.bodies[0].name);
}

TEST(WireV2, SplitKeepsEveryBodyUnderTheDatagramLimit) {
  Datagram d = one_body();
  for (int i = 0; i < 40; ++i) {
    d.bodies.push_back(d.bodies[0]);
    d.bodies.back().name = "body" + std::to_string(i);
  }
  for (const WireFormat f : {WireFormat::kBinary, WireFormat::kJson}) {
    const auto parts = split_update(d, f);
    ASSERT_GT(parts.size(), 1u);
    std::size_t bodies = 0;
    for (const auto& p : parts) {
      const auto bytes = encode(p, f);
      EXPECT_LE(bytes.size(), IPS_WIRE_MAX_DATAGRAM);
      bodies += decode_datagram(bytes).bodies.size();
    }
    EXPECT_EQ(bodies, d.bodies.size());
  }
}

}  // namespace
}  // namespace ips
