#include "ips/output/packet_codec.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/output/wire.h"

namespace ips {
namespace {

Datagram sample(bool velocity, int n_markers) {
  Datagram d;
  d.has_velocity = velocity;
  d.sequence = 0x01020304u;
  d.update = 77;
  d.capture_realtime_ns = 1'700'000'000'123'456'789;
  d.capture_monotonic_ns = 987'654'321'000;
  d.publish_realtime_ns = 1'700'000'000'133'456'789;
  for (int i = 0; i < n_markers; ++i) {
    MarkerRecord m;
    m.id = static_cast<std::uint32_t>(i + 3);
    m.camera_mask = 0x5u;
    m.x = 1.25 + i;
    m.y = -2.5;
    m.z = 0.125;
    m.yaw = -1.5;
    m.quality = 4096.0;
    m.spread = 0.0078125;
    m.dt_us = -16000;
    if (velocity) {
      m.vx = 0.5;
      m.vy = -0.25;
      m.vz = 0.0;
    }
    d.markers.push_back(m);
  }
  return d;
}

TEST(PacketCodec, BinaryBytesAreLittleEndianAtDocumentedOffsets) {
  const auto bytes = encode_binary(sample(false, 1));
  ASSERT_EQ(bytes.size(), 48u + 36u);
  // Header, checked byte by byte against the table of docs/stream.md.
  EXPECT_EQ(bytes[0], 'I');
  EXPECT_EQ(bytes[1], 'P');
  EXPECT_EQ(bytes[2], 'S');
  EXPECT_EQ(bytes[3], 'D');
  EXPECT_EQ(bytes[4], 1);  // version 1, LE
  EXPECT_EQ(bytes[5], 0);
  EXPECT_EQ(bytes[6], 0);     // flags
  EXPECT_EQ(bytes[8], 0x04);  // sequence 0x01020304 LE
  EXPECT_EQ(bytes[9], 0x03);
  EXPECT_EQ(bytes[10], 0x02);
  EXPECT_EQ(bytes[11], 0x01);
  EXPECT_EQ(bytes[12], 1);   // marker count
  EXPECT_EQ(bytes[14], 36);  // record size
  EXPECT_EQ(bytes[16], 0);   // part
  EXPECT_EQ(bytes[17], 1);   // parts
  EXPECT_EQ(bytes[20], 77);  // update
  // capture_realtime_ns = 1700000000123456789 = 0x17979CFE_3D85CD15
  const std::uint8_t t_real[8] = {0x15, 0xcd, 0x85, 0x3d, 0xfe, 0x9c, 0x97, 0x17};
  for (int i = 0; i < 8; ++i) EXPECT_EQ(bytes[24 + i], t_real[i]) << i;
  // Record: id 3, mask 5, x = 1.25f = 0x3FA00000, yaw = -1.5f = 0xBFC00000, dt_us = -16000 = 0xFFFFC180.
  EXPECT_EQ(bytes[48], 3);
  EXPECT_EQ(bytes[52], 5);
  const std::uint8_t x[4] = {0x00, 0x00, 0xa0, 0x3f};
  for (int i = 0; i < 4; ++i) EXPECT_EQ(bytes[56 + i], x[i]);
  const std::uint8_t yaw[4] = {0x00, 0x00, 0xc0, 0xbf};
  for (int i = 0; i < 4; ++i) EXPECT_EQ(bytes[68 + i], yaw[i]);
  const std::uint8_t dt[4] = {0x80, 0xc1, 0xff, 0xff};
  for (int i = 0; i < 4; ++i) EXPECT_EQ(bytes[80 + i], dt[i]);
}

void expect_same(const Datagram& a, const Datagram& b, double tol) {
  EXPECT_EQ(a.version, b.version);
  EXPECT_EQ(a.has_velocity, b.has_velocity);
  EXPECT_EQ(a.sequence, b.sequence);
  EXPECT_EQ(a.update, b.update);
  EXPECT_EQ(a.part, b.part);
  EXPECT_EQ(a.parts, b.parts);
  EXPECT_EQ(a.capture_realtime_ns, b.capture_realtime_ns);
  EXPECT_EQ(a.capture_monotonic_ns, b.capture_monotonic_ns);
  EXPECT_EQ(a.publish_realtime_ns, b.publish_realtime_ns);
  ASSERT_EQ(a.markers.size(), b.markers.size());
  for (std::size_t i = 0; i < a.markers.size(); ++i) {
    const auto& p = a.markers[i];
    const auto& q = b.markers[i];
    EXPECT_EQ(p.id, q.id);
    EXPECT_EQ(p.camera_mask, q.camera_mask);
    EXPECT_NEAR(p.x, q.x, tol);
    EXPECT_NEAR(p.y, q.y, tol);
    EXPECT_NEAR(p.z, q.z, tol);
    EXPECT_NEAR(p.yaw, q.yaw, tol);
    EXPECT_NEAR(p.quality, q.quality, 0.05);
    EXPECT_NEAR(p.spread, q.spread, tol);
    EXPECT_EQ(p.dt_us, q.dt_us);
    EXPECT_NEAR(p.vx, q.vx, tol);
    EXPECT_NEAR(p.vy, q.vy, tol);
    EXPECT_NEAR(p.vz, q.vz, tol);
  }
}

TEST(PacketCodec, RoundTripBothFormatsWithAndWithoutVelocity) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  for (bool velocity : {false, true}) {
    Datagram d = sample(velocity, 0);
    for (int i = 0; i < 7; ++i) {
      MarkerRecord m;
      m.id = static_cast<std::uint32_t>(rng() % 1000);
      m.camera_mask = rng() & 7u;
      m.x = u(rng);
      m.y = u(rng);
      m.z = u(rng) * 0.1;
      m.yaw = u(rng) * 0.6;
      m.quality = std::abs(u(rng)) * 1000;
      m.spread = std::abs(u(rng)) * 0.01;
      m.dt_us = -static_cast<std::int32_t>(rng() % 30000);
      if (velocity) {
        m.vx = u(rng) * 0.1;
        m.vy = u(rng) * 0.1;
        m.vz = u(rng) * 0.1;
      }
      d.markers.push_back(m);
    }
    const auto bin = encode_binary(d);
    EXPECT_EQ(bin.size(), 48u + 7u * (velocity ? 48u : 36u));
    expect_same(d, decode_datagram(bin), 5e-6);  // float32 near |5|: ulp ~ 5e-7
    const std::string js = encode_json(d);
    ASSERT_EQ(js.back(), '\n');
    EXPECT_TRUE(nlohmann::json::parse(js).is_object());
    const std::vector<std::uint8_t> jb(js.begin(), js.end());
    expect_same(d, decode_datagram(jb), 6e-5);  // 5 decimals (4 for velocity)
  }
}

TEST(PacketCodec, CHeaderDecoderAgreesWithEncoder) {
  const Datagram d = sample(true, 2);
  const auto bin = encode_binary(d);
  ips_wire_header h{};
  ASSERT_EQ(ips_wire_read_header(bin.data(), bin.size(), &h), IPS_WIRE_OK);
  EXPECT_EQ(h.marker_count, 2);
  EXPECT_EQ(h.flags, IPS_WIRE_FLAG_VELOCITY);
  ips_wire_marker m{};
  ips_wire_read_marker(bin.data(), &h, 1, &m);
  EXPECT_EQ(m.id, 4u);
  EXPECT_FLOAT_EQ(m.x, 2.25f);
  EXPECT_FLOAT_EQ(m.vy, -0.25f);
  EXPECT_EQ(m.dt_us, -16000);
  // A truncated copy is refused, not read past its end.
  EXPECT_EQ(ips_wire_read_header(bin.data(), bin.size() - 1, &h), IPS_WIRE_BAD_LENGTH);
}

TEST(PacketCodec, SplitKeepsEveryDatagramUnderTheLimitAndEveryMarkerOnce) {
  for (WireFormat format : {WireFormat::kBinary, WireFormat::kJson}) {
    for (bool velocity : {false, true}) {
      const Datagram d = sample(velocity, 100);
      const auto parts = split_update(d, format);
      ASSERT_GT(parts.size(), 1u);
      std::size_t total = 0;
      for (std::size_t i = 0; i < parts.size(); ++i) {
        EXPECT_EQ(parts[i].part, i);
        EXPECT_EQ(parts[i].parts, parts.size());
        auto p = parts[i];
        p.sequence = 0xffffffffu;  // widest numbers
        p.update = 0xffffffffu;
        EXPECT_LE(encode(p, format).size(), IPS_WIRE_MAX_DATAGRAM);
        for (const auto& m : parts[i].markers) EXPECT_EQ(m.id, d.markers[total++].id);
      }
      EXPECT_EQ(total, d.markers.size());
    }
  }
  // Binary without velocity: (1199 - 48) / 36 = 31 records per datagram.
  EXPECT_EQ(split_update(sample(false, 100), WireFormat::kBinary)[0].markers.size(), 31u);
  EXPECT_EQ(split_update(sample(false, 0), WireFormat::kBinary).size(), 1u);
}

TEST(PacketCodec, MalformedDatagramsAreRefusedWithAReason) {
  auto expect_refused = [](std::vector<std::uint8_t> b, const std::string& why) {
    try {
      (void)decode_datagram(b);
      ADD_FAILURE() << "accepted: " << why;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  auto good = encode_binary(sample(false, 2));
  expect_refused({}, "empty");
  expect_refused({good.begin(), good.begin() + 20}, "shorter than a header");
  auto bad = good;
  bad[0] = 'X';
  expect_refused(bad, "bad magic");
  bad = good;
  bad[4] = 3;
  expect_refused(bad, "ipsd stream version 3: this client reads versions 1 and 2; update it");
  bad = good;
  bad[4] = 2;  // version 2 needs its body section
  expect_refused(bad, "+ the body section");
  bad = good;
  bad.pop_back();
  expect_refused(bad, "does not match");
  bad = good;
  bad[16] = 1;  // part 1 of 1
  expect_refused(bad, "part 1 of 1");
  bad = good;
  ips_wire_put_f32(bad.data() + 48 + IPS_WIRE_REC_X, std::nanf(""));
  expect_refused(bad, "'x' is not a finite");
  auto js = [](const std::string& s) { return std::vector<std::uint8_t>(s.begin(), s.end()); };
  expect_refused(js("{\"type\":"), "not valid JSON");
  expect_refused(js("{\"type\":\"other\"}"), "type");
  std::string j = encode_json(sample(false, 1));
  std::string no_x = j;
  no_x.replace(no_x.find("\"x\""), 3, "\"q\"");
  expect_refused(js(no_x), "missing field 'x'");
  std::string bad_seq = j;
  bad_seq.insert(bad_seq.find("\"seq\":") + 6, 1, '-');
  expect_refused(js(bad_seq), "'seq' out of range");
}

// 10 000 random and mutated datagrams: every one is either decoded or refused with
// ips::InputError; nothing else escapes, nothing reads out of bounds (run under ASan).
TEST(PacketCodec, FuzzTenThousandDatagramsNeverCrashTheDecoder) {
  std::mt19937 rng(1234);
  const auto bin = encode_binary(sample(true, 3));
  const std::string js = encode_json(sample(true, 3));
  int decoded = 0, refused = 0;
  for (int i = 0; i < 10000; ++i) {
    std::vector<std::uint8_t> b;
    switch (i % 4) {
      case 0: {  // pure noise
        b.resize(rng() % 1300);
        for (auto& c : b) c = static_cast<std::uint8_t>(rng());
        break;
      }
      case 1: {  // valid binary with a few flipped bytes / a changed length
        b = bin;
        for (int k = 0; k < 1 + static_cast<int>(rng() % 4); ++k)
          b[rng() % b.size()] = static_cast<std::uint8_t>(rng());
        if (rng() % 3 == 0) b.resize(rng() % (b.size() + 50));
        break;
      }
      case 2: {  // valid JSON with flipped characters
        b.assign(js.begin(), js.end());
        for (int k = 0; k < 1 + static_cast<int>(rng() % 4); ++k)
          b[1 + rng() % (b.size() - 1)] = static_cast<std::uint8_t>(rng() % 128);
        break;
      }
      default: {  // noise behind a valid binary header prefix
        b.assign(bin.begin(), bin.begin() + 48);
        b.resize(48 + rng() % 200);
        for (std::size_t k = 8; k < b.size(); ++k) b[k] = static_cast<std::uint8_t>(rng());
      }
    }
    try {
      (void)decode_datagram(b);
      ++decoded;
    } catch (const InputError&) {
      ++refused;
    }
  }
  EXPECT_EQ(decoded + refused, 10000);
  EXPECT_GT(refused, 5000);  // noise is overwhelmingly refused
}

}  // namespace
}  // namespace ips
