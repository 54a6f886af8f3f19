// Clock helpers. Every frame and packet carries CLOCK_MONOTONIC and CLOCK_REALTIME
// nanoseconds so that a robot can correct for latency.
#pragma once

#include <cstdint>

namespace ips {

std::int64_t monotonic_ns();
std::int64_t realtime_ns();

/// Offset realtime - monotonic, sampled so that the two reads bracket each other as
/// tightly as possible (the minimum-width of a few tries). Used to convert a driver's
/// monotonic buffer timestamp into realtime.
std::int64_t realtime_minus_monotonic_ns();

}  // namespace ips
