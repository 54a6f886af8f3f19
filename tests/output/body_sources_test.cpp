// Body records say what placed them (wire.h: 120-byte body records with IPS_WIRE_FLAG_SOURCES):
// the bytes at their documented offsets, both formats round trip, and the records of the first
// senders (116 bytes with the flag, or no flag) read as the cameras'.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"

namespace ips {
namespace {

Datagram with_ranged_body() {
  Datagram d;
  d.version = IPS_WIRE_VERSION_2;
  d.has_sources = true;
  BodyRecord b;
  b.name = "rover";
  b.x = 1.5;
  b.y = -0.25;
  b.yaw = 0.5;
  b.has_yaw = false;  // ranges alone: the heading held
  b.sources = IPS_WIRE_SOURCE_RANGES;
  d.bodies.push_back(b);
  b.name = "seen";
  b.camera_mask = 3;
  b.has_yaw = true;
  b.sources = IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES;
  d.bodies.push_back(b);
  return d;
}

TEST(BodySources, BinaryRecordsOf120BytesCarryTheSourcesAtByte116) {
  const std::vector<std::uint8_t> bytes = encode(with_ranged_body(), WireFormat::kBinary);
  const std::size_t section = IPS_WIRE_HEADER_SIZE;  // no markers
  ASSERT_EQ(bytes.size(), section + 4 + 2 * 120u);
  EXPECT_EQ(bytes[section + 2] | bytes[section + 3] << 8, 120);  // body_record_size
  const std::size_t first = section + 4, second = first + 120;
  EXPECT_EQ(bytes[first + 116], IPS_WIRE_SOURCE_RANGES);  // little-endian u16 = 2
  EXPECT_EQ(bytes[first + 117], 0);
  EXPECT_EQ(bytes[second + 116], 3);
  EXPECT_EQ(bytes[first + 118] | bytes[first + 119], 0);  // reserved
  const Datagram back = decode_datagram(bytes);
  ASSERT_EQ(back.bodies.size(), 2u);
  EXPECT_EQ(back.bodies[0].sources, IPS_WIRE_SOURCE_RANGES);
  EXPECT_FALSE(back.bodies[0].has_yaw);
  EXPECT_EQ(back.bodies[1].sources, IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES);
}

TEST(BodySources, JsonNamesThemAndReadsThemBack) {
  const std::vector<std::uint8_t> bytes = encode(with_ranged_body(), WireFormat::kJson);
  const std::string text(bytes.begin(), bytes.end());
  EXPECT_NE(text.find(R"("name":"rover")"), std::string::npos);
  EXPECT_NE(text.find(R"("sources":["ranges"]})"), std::string::npos) << text;
  EXPECT_NE(text.find(R"("sources":["camera","ranges"]})"), std::string::npos) << text;
  const Datagram back = decode_datagram(bytes);
  ASSERT_EQ(back.bodies.size(), 2u);
  EXPECT_EQ(back.bodies[0].sources, IPS_WIRE_SOURCE_RANGES);
  EXPECT_EQ(back.bodies[1].sources, IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES);
}

TEST(BodySources, RecordsOfTheFirstSendersAreTheCameras) {
  // No sources flag: 116-byte records, nothing at 116.
  Datagram d = with_ranged_body();
  d.has_sources = false;
  std::vector<std::uint8_t> bytes = encode(d, WireFormat::kBinary);
  ASSERT_EQ(bytes.size(), IPS_WIRE_HEADER_SIZE + 4 + 2 * 116u);
  for (const BodyRecord& b : decode_datagram(bytes).bodies) EXPECT_EQ(b.sources, IPS_WIRE_SOURCE_CAMERA);
  // The flag set but 116-byte body records (the first ipsd with ranges and bodies).
  bytes[IPS_WIRE_OFF_FLAGS] |= IPS_WIRE_FLAG_SOURCES;
  bytes[IPS_WIRE_OFF_RECORD_SIZE] = IPS_WIRE_RECORD_SIZE_SOURCES;  // (no marker records follow)
  for (const BodyRecord& b : decode_datagram(bytes).bodies) EXPECT_EQ(b.sources, IPS_WIRE_SOURCE_CAMERA);
  // JSON bodies without "sources" in a datagram with sources: the cameras.
  const std::vector<std::uint8_t> with = encode(with_ranged_body(), WireFormat::kJson);
  std::string json(with.begin(), with.end());
  for (const std::string cut : {R"(,"sources":["ranges"])", R"(,"sources":["camera","ranges"])"})
    json.erase(json.find(cut), cut.size());
  ASSERT_NE(json.find(R"("sources":true)"), std::string::npos);
  const Datagram j = decode_datagram(std::vector<std::uint8_t>(json.begin(), json.end()));
  ASSERT_EQ(j.bodies.size(), 2u);
  for (const BodyRecord& b : j.bodies) EXPECT_EQ(b.sources, IPS_WIRE_SOURCE_CAMERA);
}

}  // namespace
}  // namespace ips
