// One configured output (outputs[i]) as the publisher sees it. Every output type (ipsd's own UDP
// datagrams today; other protocols later) implements this interface in src/output/, and
// make_output_sink() is the one place that maps a config type to its implementation.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ips/output/output_settings.h"
#include "ips/output/packet_codec.h"

namespace ips {

/// A failing output logs its send errors at most once per this interval (they are counted always).
inline constexpr std::int64_t kSendErrorLogIntervalNs = 10'000'000'000;

struct OutputStats {
  std::string description;      ///< "unicast 127.0.0.1:5005 (binary)"
  std::uint64_t datagrams = 0;  ///< sent successfully (datagrams, frames or samples)
  std::uint64_t bytes = 0;
  std::uint64_t send_errors = 0;  ///< failed sends (EAGAIN, unreachable, ...): data lost
  /// Type-specific counters shown by the status, in order ({"subscribers", 2}, {"refused_subnet", 5}, ...).
  std::vector<std::pair<std::string, std::uint64_t>> counters;
};

class OutputSink {
 public:
  virtual ~OutputSink() = default;
  /// Sends one fused update. Called on the fusion thread: must never block (a full socket buffer
  /// or a slow peer is counted as an error or a drop, never waited for).
  virtual void publish(const Datagram& update) = 0;
  virtual OutputStats stats() const = 0;
  /// Capture -> send latency of the last thing sent, ns (CLOCK_REALTIME difference); 0 = none yet.
  virtual std::int64_t last_latency_ns() const { return 0; }
};

/// Opens the output `config` (= outputs[index]). Throws ips::InputError naming `outputs[index].key`
/// for a value that is wrong for its type (an address that is not IPv4, ...).
std::unique_ptr<OutputSink> make_output_sink(const OutputConfig& config, int index);

}  // namespace ips
