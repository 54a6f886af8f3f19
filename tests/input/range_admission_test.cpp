// The range input's rules for one datagram (RangeAdmission), with the clocks given by the test:
// the subnet, the rate, the key, unknown tags and anchors, the sender's clock, duplicates and
// the reorder window; and the same through a real UDP socket (RangeInput).
#include "ips/input/range_admission.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/input/range_input.h"

namespace ips {
namespace {

constexpr std::uint32_t kLab = 0x0A000105;    // 10.0.1.5
constexpr std::uint32_t kOther = 0xC0A80002;  // 192.168.0.2
constexpr std::int64_t kMono = 5'000'000'000'000;
constexpr std::int64_t kReal = 1'800'000'000'000'000'000;
constexpr std::int64_t kMs = 1'000'000;

RangeInputSettings settings() {
  RangeInputSettings s;
  s.allow = {"10.0.0.0/16"};
  s.tags = {7, 8};
  s.anchors = {1, 2, 3, 4};
  s.rate_per_source_hz = 50;
  return s;
}

RangeFiring firing(std::uint32_t n, std::int64_t real_ns, std::vector<RangeEntry> entries = {}) {
  RangeFiring f;
  f.tag = 7;
  f.firing = n;
  f.firing_realtime_ns = real_ns;
  f.entries = entries.empty() ? std::vector<RangeEntry>{{1, false, 2.0, 0.05}, {2, false, 3.0, 0.05}} : entries;
  return f;
}

std::size_t refused(const RangeAdmission& a, RangeRefusal why) {
  return a.counters().refused[static_cast<std::size_t>(why)];
}

TEST(RangeAdmission, AFiringIsPlacedOnThisHostsMonotonicClockByItsSendersRealtime) {
  RangeAdmission a(settings(), "ranging");
  // Fired 40 ms before it arrived (a delayed packet): placed 40 ms before the arrival.
  auto f = a.admit(encode_range_firing(firing(1, kReal - 40 * kMs), ""), kLab, 4000, kMono, kReal);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->t_mono_ns, kMono - 40 * kMs);
  EXPECT_EQ(f->source_address, kLab);
  // No sender time: the arrival.
  f = a.admit(encode_range_firing(firing(2, 0), ""), kLab, 4000, kMono + 5 * kMs, kReal + 5 * kMs);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->t_mono_ns, kMono + 5 * kMs);
  EXPECT_EQ(a.counters().accepted, 2u);
}

TEST(RangeAdmission, OutsideAllowOverTheRateOrWithoutTheKeyIsRefusedAndCounted) {
  RangeInputSettings s = settings();
  s.psk = "lab key";
  RangeAdmission a(s, "ranging");
  EXPECT_FALSE(a.admit(encode_range_firing(firing(1, 0), "lab key"), kOther, 4000, kMono, kReal));
  EXPECT_EQ(refused(a, RangeRefusal::kSubnet), 1u);
  EXPECT_FALSE(a.admit(encode_range_firing(firing(1, 0), ""), kLab, 4000, kMono, kReal));
  EXPECT_EQ(refused(a, RangeRefusal::kKey), 1u);
  EXPECT_FALSE(a.admit(encode_range_firing(firing(1, 0), "guess"), kLab, 4000, kMono, kReal));
  EXPECT_EQ(refused(a, RangeRefusal::kKey), 2u);
  EXPECT_FALSE(a.admit(std::vector<std::uint8_t>(40, 0), kLab, 4000, kMono, kReal));
  EXPECT_EQ(refused(a, RangeRefusal::kMalformed), 1u);
  EXPECT_TRUE(a.admit(encode_range_firing(firing(1, 0), "lab key"), kLab, 4000, kMono, kReal));

  // The rate: 50 firings/s with a burst of one second's worth. 4 taken already from kLab; a
  // burst of 100 in one instant: 46 more are taken, 54 refused; half a second later 25 more.
  std::size_t taken = 0;
  for (std::uint32_t n = 2; n < 102; ++n)
    taken += a.admit(encode_range_firing(firing(n, 0), "lab key"), kLab, 4000, kMono, kReal).has_value();
  EXPECT_EQ(taken, 46u);
  EXPECT_EQ(refused(a, RangeRefusal::kRate), 54u);
  taken = 0;
  for (std::uint32_t n = 200; n < 300; ++n)
    taken += a.admit(encode_range_firing(firing(n, 0), "lab key"), kLab, 4000, kMono + 500 * kMs, kReal).has_value();
  EXPECT_EQ(taken, 25u);
  // Another source has its own bucket.
  EXPECT_TRUE(a.admit(encode_range_firing(firing(400, 0), "lab key"), kLab + 1, 4000, kMono + 500 * kMs, kReal));
  EXPECT_EQ(a.counters().datagrams, 5u + 100u + 100u + 1u);
}

TEST(RangeAdmission, UnknownTagsAreDroppedUnknownReferencesLeftOut) {
  RangeAdmission a(settings(), "ranging");
  RangeFiring f = firing(1, 0, {{1, false, 2.0, 0.05}, {9, false, 1.0, 0.05}, {8, true, 1.5, 0.05}, {5, true, 1, 0}});
  const auto taken = a.admit(encode_range_firing(f, ""), kLab, 4000, kMono, kReal);
  ASSERT_TRUE(taken);
  ASSERT_EQ(taken->firing.entries.size(), 2u);  // anchor 1 and tag 8; anchor 9 and tag 5 unknown
  EXPECT_EQ(taken->firing.entries[0].reference, 1u);
  EXPECT_EQ(taken->firing.entries[1].reference, 8u);
  EXPECT_TRUE(taken->firing.entries[1].reference_is_tag);
  EXPECT_EQ(a.counters().unknown_references, 2u);
  f.tag = 3;
  EXPECT_FALSE(a.admit(encode_range_firing(f, ""), kLab, 4000, kMono, kReal));
  EXPECT_EQ(refused(a, RangeRefusal::kUnknownTag), 1u);
  EXPECT_FALSE(a.admit(encode_range_firing(firing(2, 0, {{9, false, 1.0, 0.05}}), ""), kLab, 4000, kMono, kReal));
  EXPECT_EQ(refused(a, RangeRefusal::kNoKnownReference), 1u);
}

TEST(RangeAdmission, DuplicatesAndFiringsBeyondTheReorderWindowAreDroppedOthersTakenInAnyOrder) {
  RangeAdmission a(settings(), "ranging");  // reorder window 0.3 s
  const auto at = [&](std::uint32_t n, std::int64_t fired_ms, std::int64_t arrived_ms) {
    return a.admit(encode_range_firing(firing(n, kReal + fired_ms * kMs), ""), kLab, 4000, kMono + arrived_ms * kMs,
                   kReal + arrived_ms * kMs);
  };
  EXPECT_TRUE(at(10, 0, 5));
  EXPECT_TRUE(at(12, 200, 205));
  EXPECT_TRUE(at(11, 100, 290));   // late, within the window: taken (fusion orders by time)
  EXPECT_FALSE(at(11, 100, 291));  // the same firing again
  EXPECT_EQ(refused(a, RangeRefusal::kDuplicate), 1u);
  EXPECT_TRUE(at(13, 1000, 1001));
  EXPECT_FALSE(at(9, 650, 1100));  // 350 ms before tag 7's newest
  EXPECT_EQ(refused(a, RangeRefusal::kTooOld), 1u);
  EXPECT_TRUE(at(14, 750, 1100));  // 250 ms before: taken
  // A sender clock 2 s ahead of this host's.
  EXPECT_FALSE(at(15, 3200, 1200));
  EXPECT_EQ(refused(a, RangeRefusal::kClock), 1u);
  // Firing numbers wrap: 2^32 - 1 then 0 are two firings.
  EXPECT_TRUE(at(0xFFFFFFFFu, 1300, 1301));
  EXPECT_TRUE(at(0, 1400, 1401));
}

TEST(RangeAdmission, AnAllowEntryThatIsNotASubnetIsAConfigError) {
  RangeInputSettings s = settings();
  s.allow = {"10.0.0.0/16", "10.0.0.1/8"};
  try {
    RangeAdmission a(s, "ranging");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ranging.allow[1]"), std::string::npos) << e.what();
  }
}

TEST(RangeInput, FiringsSentToItsPortReachTheHandlerAndRefusalsAreCounted) {
  RangeInputSettings s = settings();
  s.address = "127.0.0.1";
  s.allow = {"127.0.0.0/8"};
  std::mutex m;
  std::condition_variable cv;
  std::vector<AdmittedFiring> got;
  RangeInput input(s, "ranging", [&](AdmittedFiring&& f) {
    std::lock_guard lock(m);
    got.push_back(std::move(f));
    cv.notify_all();
  });
  ASSERT_NE(input.port(), 0);
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(input.port());
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const auto send = [&](const std::vector<std::uint8_t>& b) {
    ASSERT_EQ(::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(b.size()));
  };
  const std::int64_t sent_mono = monotonic_ns();
  send(encode_range_firing(firing(1, 0), ""));
  send({1, 2, 3});
  send(encode_range_firing(firing(1, 0), ""));  // duplicate
  send(encode_range_firing(firing(2, realtime_ns()), ""));
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(10), [&] { return got.size() >= 2; }));
  }
  ::close(fd);
  for (int i = 0; i < 100 && input.counters().datagrams < 4; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const RangeInputCounters c = input.counters();
  EXPECT_EQ(c.datagrams, 4u);
  EXPECT_EQ(c.accepted, 2u);
  EXPECT_EQ(c.refused[static_cast<std::size_t>(RangeRefusal::kMalformed)], 1u);
  EXPECT_EQ(c.refused[static_cast<std::size_t>(RangeRefusal::kDuplicate)], 1u);
  std::lock_guard lock(m);
  EXPECT_EQ(got[0].firing.firing, 1u);
  EXPECT_EQ(got[1].firing.firing, 2u);
  EXPECT_GE(got[0].t_mono_ns, sent_mono);
  EXPECT_EQ(got[0].source_address, 0x7F000001u);
}

}  // namespace
}  // namespace ips
