// The range input's datagram (include/ips/input/range_wire.h): bytes written out by hand from
// the layout, an independent encoder (tools/send_ranges.py, Python's struct and hmac), and
// every refusal rule.
#include "ips/input/range_datagram.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "ips/input/range_wire.h"

namespace ips {
namespace {

// tag 7, firing 42, time 0x0102030405060708 ns, anchor 1 at 2.5 m (sigma 0.25), tag 8 at 0.5 m
// (sigma 0 = configured), odometry 1.0 m +- 0.25 m.
const std::vector<std::uint8_t> kHandWritten = {
    'I',  'P',  'S',  'R',                           // magic
    1,                                               // version
    0x01,                                            // flags: odometry
    2,    0,                                         // entry_count
    7,    0,    0,    0,                             // tag
    42,   0,    0,    0,                             // firing
    0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,  // firing_realtime_ns
    12,   0,                                         // entry_size
    0,    0,                                         // reserved
    0x00, 0x00, 0x80, 0x3F,                          // odometry_m 1.0
    0x00, 0x00, 0x80, 0x3E,                          // odometry_sigma_m 0.25
    0,    0,    0,    0,                             // reserved
    1,    0,    0,    0,                             // anchor 1
    0x00, 0x00, 0x20, 0x40,                          // 2.5 m
    0x00, 0x00, 0x80, 0x3E,                          // sigma 0.25
    8,    0,    0,    0x80,                          // tag 8 (bit 31)
    0x00, 0x00, 0x00, 0x3F,                          // 0.5 m
    0,    0,    0,    0,                             // sigma 0
};

RangeFiring hand_written_firing() {
  RangeFiring f;
  f.tag = 7;
  f.firing = 42;
  f.firing_realtime_ns = 0x0102030405060708LL;
  f.entries = {{1, false, 2.5, 0.25}, {8, true, 0.5, 0.0}};
  f.odometry_m = 1.0;
  f.odometry_sigma_m = 0.25;
  return f;
}

std::optional<RangeFiring> decode(const std::vector<std::uint8_t>& b, const std::string& psk = "",
                                  RangeDatagramError* error = nullptr, std::string* why = nullptr) {
  RangeDatagramError e;
  std::string w;
  auto f = decode_range_firing(b, psk, e, w);
  if (error) *error = e;
  if (why) *why = w;
  return f;
}

TEST(RangeDatagram, EncodesTheHandWrittenBytesAndDecodesThem) {
  EXPECT_EQ(encode_range_firing(hand_written_firing(), ""), kHandWritten);
  const auto f = decode(kHandWritten);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->tag, 7u);
  EXPECT_EQ(f->firing, 42u);
  EXPECT_EQ(f->firing_realtime_ns, 0x0102030405060708LL);
  ASSERT_EQ(f->entries.size(), 2u);
  EXPECT_EQ(f->entries[0].reference, 1u);
  EXPECT_FALSE(f->entries[0].reference_is_tag);
  EXPECT_EQ(f->entries[0].range_m, 2.5);
  EXPECT_EQ(f->entries[0].sigma_m, 0.25);
  EXPECT_EQ(f->entries[1].reference, 8u);
  EXPECT_TRUE(f->entries[1].reference_is_tag);
  EXPECT_EQ(f->entries[1].range_m, 0.5);
  ASSERT_TRUE(f->odometry_m);
  EXPECT_EQ(*f->odometry_m, 1.0);
  EXPECT_EQ(f->odometry_sigma_m, 0.25);
}

TEST(RangeDatagram, ALongerEntryFromALaterRevisionIsSteppedOver) {
  // entry_size 16: four bytes appended to every entry, which this reader skips.
  std::vector<std::uint8_t> b(kHandWritten.begin(), kHandWritten.begin() + IPS_RANGE_HEADER_SIZE);
  b[IPS_RANGE_OFF_ENTRY_SIZE] = 16;
  for (int e = 0; e < 2; ++e) {
    const auto* entry = kHandWritten.data() + IPS_RANGE_HEADER_SIZE + 12 * e;
    b.insert(b.end(), entry, entry + 12);
    b.insert(b.end(), {0xAA, 0xBB, 0xCC, 0xDD});
  }
  const auto f = decode(b);
  ASSERT_TRUE(f);
  ASSERT_EQ(f->entries.size(), 2u);
  EXPECT_EQ(f->entries[1].reference, 8u);
  EXPECT_EQ(f->entries[1].range_m, 0.5);
}

TEST(RangeDatagram, WithAKeyTheHmacIsRequiredAndChecked) {
  const auto signed_bytes = encode_range_firing(hand_written_firing(), "lab key");
  ASSERT_EQ(signed_bytes.size(), kHandWritten.size() + IPS_RANGE_MAC_SIZE);
  EXPECT_TRUE(decode(signed_bytes, "lab key"));
  RangeDatagramError error;
  std::string why;
  EXPECT_FALSE(decode(signed_bytes, "other key", &error, &why));
  EXPECT_EQ(error, RangeDatagramError::kBadKey) << why;
  EXPECT_FALSE(decode(kHandWritten, "lab key", &error, &why));
  EXPECT_EQ(error, RangeDatagramError::kBadKey) << why;
  EXPECT_FALSE(decode(signed_bytes, "", &error, &why));
  EXPECT_EQ(error, RangeDatagramError::kBadKey) << why;
  auto flipped = signed_bytes;
  flipped[IPS_RANGE_HEADER_SIZE + 4] ^= 0x01;  // one bit of a range
  EXPECT_FALSE(decode(flipped, "lab key", &error, &why));
  EXPECT_EQ(error, RangeDatagramError::kBadKey);
}

TEST(RangeDatagram, EveryBrokenRuleIsRefusedWithAReason) {
  struct Case {
    const char* name;
    std::size_t offset;
    std::vector<std::uint8_t> bytes;  // written at offset
  };
  const std::vector<Case> cases = {
      {"magic", 0, {'I', 'P', 'S', 'D'}},
      {"version", IPS_RANGE_OFF_VERSION, {2}},
      {"flag bits", IPS_RANGE_OFF_FLAGS, {0x03}},
      {"zero entries", IPS_RANGE_OFF_ENTRY_COUNT, {0, 0}},
      {"more entries than bytes", IPS_RANGE_OFF_ENTRY_COUNT, {3, 0}},
      {"too many entries", IPS_RANGE_OFF_ENTRY_COUNT, {65, 0}},
      {"short entry_size", IPS_RANGE_OFF_ENTRY_SIZE, {8, 0}},
      {"tag >= 2^31", IPS_RANGE_OFF_TAG + 3, {0x80}},
      {"negative time", IPS_RANGE_OFF_FIRING_REALTIME + 7, {0x81}},
      {"NaN odometry", IPS_RANGE_OFF_ODOMETRY, {0x00, 0x00, 0xC0, 0x7F}},
      {"NaN range", IPS_RANGE_HEADER_SIZE + 4, {0x00, 0x00, 0xC0, 0x7F}},
      {"negative range", IPS_RANGE_HEADER_SIZE + 4, {0x00, 0x00, 0x80, 0xBF}},
      {"huge range", IPS_RANGE_HEADER_SIZE + 4, {0x00, 0x00, 0x80, 0x7F}},
      {"negative sigma", IPS_RANGE_HEADER_SIZE + 8, {0x00, 0x00, 0x80, 0xBE}},
      {"repeated reference", IPS_RANGE_HEADER_SIZE + 12, {1, 0, 0, 0}},
      {"ranges to itself", IPS_RANGE_HEADER_SIZE + 12, {7, 0, 0, 0x80}},
  };
  for (const Case& c : cases) {
    auto b = kHandWritten;
    std::copy(c.bytes.begin(), c.bytes.end(), b.begin() + static_cast<std::ptrdiff_t>(c.offset));
    RangeDatagramError error;
    std::string why;
    EXPECT_FALSE(decode(b, "", &error, &why)) << c.name;
    EXPECT_EQ(error, RangeDatagramError::kMalformed) << c.name;
    EXPECT_FALSE(why.empty()) << c.name;
  }
  // Odometry values without the flag.
  auto b = kHandWritten;
  b[IPS_RANGE_OFF_FLAGS] = 0;
  EXPECT_FALSE(decode(b));
  // Every truncation.
  for (std::size_t n = 0; n < kHandWritten.size(); ++n)
    EXPECT_FALSE(decode(std::vector<std::uint8_t>(kHandWritten.begin(), kHandWritten.begin() + n))) << n;
}

TEST(RangeDatagram, TheEncoderRefusesWhatNoReceiverWouldTake) {
  RangeFiring f = hand_written_firing();
  f.entries.clear();
  EXPECT_THROW(encode_range_firing(f, ""), std::invalid_argument);
  f = hand_written_firing();
  f.entries[0].range_m = -1;
  EXPECT_THROW(encode_range_firing(f, ""), std::invalid_argument);
  f = hand_written_firing();
  f.tag = 0x80000000u;
  EXPECT_THROW(encode_range_firing(f, ""), std::invalid_argument);
}

// tools/send_ranges.py is an independent encoder (Python's struct and hmac, from the layout in
// range_wire.h). It sends to a port here; the C++ decoder must read what it meant.
TEST(RangeDatagram, ThePythonSendersBytesDecode) {
  const char* python = "/usr/bin/python3";
  if (!std::filesystem::exists(python)) GTEST_SKIP() << "no python3";
  const std::string sender = std::string(IPS_CONFIG_DIR) + "/../tools/send_ranges.py";
  const auto out = std::filesystem::temp_directory_path() / ("send_ranges_" + std::to_string(::getpid()) + ".bin");
  // Capture with a one-shot Python receiver would add a second script; instead a tiny
  // wrapper replaces the socket call and writes the bytes to a file.
  const std::string cmd = std::string(python) + " -c \"import socket,sys,runpy; " +
                          "socket.socket.sendto=lambda s,d,a: open('" + out.string() + "','wb').write(d); " +
                          "sys.argv=['send_ranges.py','127.0.0.1:9','--tag','7','--firing','42','--ref','1:2.5:0.25'," +
                          "'--ref','tag:8:0.5','--odometry','1.0','0.25','--time-ns','72623859790382856'," +
                          "'--psk','lab key']; runpy.run_path('" + sender + "', run_name='__main__')\"";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(out, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove(out);
  EXPECT_EQ(bytes, encode_range_firing(hand_written_firing(), "lab key"));
}

}  // namespace
}  // namespace ips
