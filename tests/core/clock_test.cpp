#include "ips/core/clock.h"

#include <gtest/gtest.h>

#include <cstdlib>

namespace {

TEST(Clock, MonotonicNeverGoesBack) {
  std::int64_t last = ips::monotonic_ns();
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t now = ips::monotonic_ns();
    ASSERT_GE(now, last);
    last = now;
  }
}

TEST(Clock, OffsetConvertsMonotonicToRealtime) {
  const std::int64_t offset = ips::realtime_minus_monotonic_ns();
  const std::int64_t predicted = ips::monotonic_ns() + offset;
  const std::int64_t actual = ips::realtime_ns();
  // Both reads are within microseconds of each other; 50 ms allows for a loaded machine.
  EXPECT_LT(std::llabs(actual - predicted), 50'000'000);
  // Realtime is after 2020 on any machine that runs this.
  EXPECT_GT(actual, 1'577'836'800LL * 1'000'000'000LL);
}

}  // namespace
