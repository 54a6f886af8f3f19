#include "ips/core/clock.h"

#include <ctime>
#include <limits>

namespace ips {
namespace {
std::int64_t read_ns(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
}  // namespace

std::int64_t monotonic_ns() { return read_ns(CLOCK_MONOTONIC); }
std::int64_t realtime_ns() { return read_ns(CLOCK_REALTIME); }

std::int64_t realtime_minus_monotonic_ns() {
  std::int64_t best_width = std::numeric_limits<std::int64_t>::max();
  std::int64_t best_offset = 0;
  for (int i = 0; i < 5; ++i) {
    const std::int64_t m0 = monotonic_ns();
    const std::int64_t r = realtime_ns();
    const std::int64_t m1 = monotonic_ns();
    if (m1 - m0 < best_width) {
      best_width = m1 - m0;
      best_offset = r - (m0 + (m1 - m0) / 2);
    }
  }
  return best_offset;
}

}  // namespace ips
