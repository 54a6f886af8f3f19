// The sources revision of the marker record (IPS_WIRE_FLAG_SOURCES, include/ips/output/wire.h):
// the bytes are where the layout says (checked against offsets written out by hand), both
// encodings and the Python client carry them alike, a receiver written before the revision
// still reads every marker, and a stream without the flag reads as cameras with a heading.
#include <cstring>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"

namespace ips {
namespace {

// A camera-seen marker and one placed by ranges alone (no camera, heading held).
Datagram two_sources(bool velocity) {
  Datagram d;
  d.has_sources = true;
  d.has_velocity = velocity;
  d.sequence = 9;
  d.update = 3;
  MarkerRecord seen;
  seen.id = 4;
  seen.camera_mask = 3;
  seen.x = 1.25;
  seen.yaw = 0.5;
  seen.quality = 900;
  seen.sources = IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES;
  seen.has_yaw = true;
  seen.vx = 0.25;
  MarkerRecord ranged;
  ranged.id = 20;
  ranged.camera_mask = 0;
  ranged.x = -2.5;
  ranged.y = 0.75;
  ranged.yaw = 1.0;  // the last heading, held
  ranged.sources = IPS_WIRE_SOURCE_RANGES;
  ranged.has_yaw = false;
  ranged.vx = -0.5;
  d.markers = {seen, ranged};
  return d;
}

std::uint16_t u16_at(const std::vector<std::uint8_t>& b, std::size_t off) {
  return static_cast<std::uint16_t>(b[off] | (b[off + 1] << 8));
}
std::uint32_t u32_at(const std::vector<std::uint8_t>& b, std::size_t off) {
  return static_cast<std::uint32_t>(u16_at(b, off)) | static_cast<std::uint32_t>(u16_at(b, off + 2)) << 16;
}
float f32_at(const std::vector<std::uint8_t>& b, std::size_t off) {
  float f;
  std::memcpy(&f, b.data() + off, 4);  // little-endian host (x86/ARM), as the test machine is
  return f;
}

TEST(WireSources, TheRecordIs52BytesWithSourcesAndFlagsAtBytes48And50) {
  const auto bytes = encode_binary(two_sources(false));
  ASSERT_EQ(bytes.size(), 48u + 2u * 52u);
  EXPECT_EQ(u16_at(bytes, 6), 0x0002u) << "header flags: sources, no velocity";
  EXPECT_EQ(u16_at(bytes, 14), 52u) << "record_size";
  const std::size_t r0 = 48, r1 = 48 + 52;
  EXPECT_EQ(u16_at(bytes, r0 + 48), 0x0003u) << "camera | ranges";
  EXPECT_EQ(u16_at(bytes, r0 + 50), 0x0001u) << "has yaw";
  EXPECT_EQ(u16_at(bytes, r1 + 48), 0x0002u) << "ranges alone";
  EXPECT_EQ(u16_at(bytes, r1 + 50), 0x0000u) << "heading held";
  // Without the velocity flag the velocity bytes are there and zero.
  for (std::size_t off = 36; off < 48; ++off) EXPECT_EQ(bytes[r1 + off], 0u) << "byte " << off;

  const auto with_velocity = encode_binary(two_sources(true));
  ASSERT_EQ(with_velocity.size(), bytes.size()) << "the velocity fields are always in a 52-byte record";
  EXPECT_EQ(u16_at(with_velocity, 6), 0x0003u);
  EXPECT_FLOAT_EQ(f32_at(with_velocity, r1 + 36), -0.5f);
  EXPECT_EQ(u16_at(with_velocity, r1 + 48), 0x0002u);
}

TEST(WireSources, BothEncodingsAndTheCHelpersReadTheSources) {
  for (const bool velocity : {false, true}) {
    const Datagram d = two_sources(velocity);
    const auto bytes = encode_binary(d);
    ips_wire_header h{};
    ASSERT_EQ(ips_wire_read_header(bytes.data(), bytes.size(), &h), IPS_WIRE_OK);
    ips_wire_marker m{};
    ips_wire_read_marker(bytes.data(), &h, 1, &m);
    EXPECT_EQ(m.sources, IPS_WIRE_SOURCE_RANGES);
    EXPECT_EQ(m.marker_flags, 0u);
    EXPECT_FLOAT_EQ(m.vx, velocity ? -0.5f : 0.0f);

    const std::string json = encode_json(d);
    EXPECT_NE(json.find("\"sources\":true"), std::string::npos) << json;
    EXPECT_NE(json.find("\"sources\":[\"camera\",\"ranges\"],\"has_yaw\":true"), std::string::npos) << json;
    EXPECT_NE(json.find("\"sources\":[\"ranges\"],\"has_yaw\":false"), std::string::npos) << json;
    for (const Datagram& back :
         {decode_datagram(bytes),
          decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(json.data()), json.size()))}) {
      EXPECT_TRUE(back.has_sources);
      ASSERT_EQ(back.markers.size(), 2u);
      EXPECT_EQ(back.markers[0].sources, IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES);
      EXPECT_TRUE(back.markers[0].has_yaw);
      EXPECT_EQ(back.markers[1].sources, IPS_WIRE_SOURCE_RANGES);
      EXPECT_FALSE(back.markers[1].has_yaw);
      EXPECT_EQ(back.markers[1].camera_mask, 0u);
      EXPECT_DOUBLE_EQ(back.markers[1].x, -2.5);
    }
  }
}

// A robot's own camera (docs/inside-out.md) is bit 2, "inside-out" in JSON; with an overhead
// camera's bit where both placed the robot.
TEST(WireSources, TheRobotsOwnCameraIsBit2AndNamedInsideOut) {
  Datagram d = two_sources(true);
  d.markers[0].sources = IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_INSIDE_OUT;
  d.markers[1].sources = IPS_WIRE_SOURCE_INSIDE_OUT;
  d.markers[1].has_yaw = true;  // the robot's camera measures the heading
  const auto bytes = encode_binary(d);
  EXPECT_EQ(u16_at(bytes, IPS_WIRE_HEADER_SIZE + IPS_WIRE_RECORD_SIZE_SOURCES + 48), 4u);
  const std::string json = encode_json(d);
  EXPECT_NE(json.find("\"sources\":[\"camera\",\"inside-out\"],\"has_yaw\":true"), std::string::npos) << json;
  EXPECT_NE(json.find("\"sources\":[\"inside-out\"],\"has_yaw\":true"), std::string::npos) << json;
  for (const Datagram& back :
       {decode_datagram(bytes),
        decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(json.data()), json.size()))}) {
    ASSERT_EQ(back.markers.size(), 2u);
    EXPECT_EQ(back.markers[0].sources, IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_INSIDE_OUT);
    EXPECT_EQ(back.markers[1].sources, IPS_WIRE_SOURCE_INSIDE_OUT);
    EXPECT_TRUE(back.markers[1].has_yaw);
  }
}

TEST(WireSources, AReceiverWrittenBeforeTheRevisionStillReadsEveryMarker) {
  // What a version-1 receiver does (the layout of the first ipsd): check record_size against
  // the velocity flag only, step by record_size, read the fields it knows.
  const auto bytes = encode_binary(two_sources(true));
  const std::uint16_t flags = u16_at(bytes, 6), count = u16_at(bytes, 12), record_size = u16_at(bytes, 14);
  ASSERT_GE(record_size, (flags & 1u) ? 48u : 36u);
  ASSERT_EQ(bytes.size(), 48u + count * record_size);
  std::vector<std::uint32_t> ids;
  std::vector<float> xs, vxs;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t r = 48 + i * record_size;
    ids.push_back(u32_at(bytes, r));
    xs.push_back(f32_at(bytes, r + 8));
    vxs.push_back(f32_at(bytes, r + 36));
  }
  EXPECT_EQ(ids, (std::vector<std::uint32_t>{4, 20}));
  EXPECT_EQ(xs, (std::vector<float>{1.25f, -2.5f}));
  EXPECT_EQ(vxs, (std::vector<float>{0.25f, -0.5f}));
  // JSON receivers read fields by name: the new keys are extra keys.
}

TEST(WireSources, AStreamWithoutTheFlagReadsAsCamerasWithAHeading) {
  Datagram d = two_sources(false);
  d.has_sources = false;
  const auto bytes = encode_binary(d);
  EXPECT_EQ(u16_at(bytes, 14), 36u) << "the record of a daemon without ranging is unchanged";
  const std::string json = encode_json(d);
  EXPECT_EQ(json.find("sources"), std::string::npos) << json;
  for (const Datagram& back :
       {decode_datagram(bytes),
        decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(json.data()), json.size()))}) {
    EXPECT_FALSE(back.has_sources);
    for (const MarkerRecord& m : back.markers) {
      EXPECT_EQ(m.sources, IPS_WIRE_SOURCE_CAMERA);
      EXPECT_TRUE(m.has_yaw);
    }
  }
}

TEST(WireSources, MalformedSourcesAreRefusedNamingTheField) {
  // A flag that announces more than the records hold.
  auto bytes = encode_binary(two_sources(true));
  bytes[14] = 48;  // record_size 48 with IPS_WIRE_FLAG_SOURCES
  bytes.resize(48 + 2 * 48);
  try {
    (void)decode_datagram(bytes);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("record_size 48 too small"), std::string::npos) << e.what();
  }
  // JSON: the header says sources, a marker has none / a mistyped one.
  const std::string base =
      R"({"type":"ips.positions","version":1,"seq":1,"update":1,"part":0,"parts":1,"t_capture_real_ns":0,)"
      R"("t_capture_mono_ns":0,"t_publish_real_ns":0,"velocity":false,"sources":true,"markers":[{"id":1,)"
      R"("cameras":0,"x":0,"y":0,"z":0,"yaw":0,"quality":0,"spread":0,"dt_us":0)";
  for (const auto& [tail, field] :
       std::vector<std::pair<std::string, std::string>>{{"}]}", "'sources'"},
                                                        {R"(,"sources":"ranges","has_yaw":false}]})", "'sources'"},
                                                        {R"(,"sources":["ranges"]}]})", "'has_yaw'"},
                                                        {R"(,"sources":[7],"has_yaw":false}]})", "source"}}) {
    const std::string text = base + tail;
    try {
      (void)decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
      FAIL() << "accepted " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
  // A later source's name is skipped, not refused (a newer daemon, this receiver).
  const std::string later = base + R"(,"sources":["ranges","inside_out"],"has_yaw":false}]})";
  const Datagram d = decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(later.data()), later.size()));
  EXPECT_EQ(d.markers.at(0).sources, IPS_WIRE_SOURCE_RANGES);
}

}  // namespace
}  // namespace ips
