// Sends fused updates to every configured output, each through its own OutputSink (see
// output_sink.h). Sinks never block: a full send buffer or a network error is counted and logged
// (rate-limited), never fatal, and never stalls the caller.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "ips/output/output_settings.h"
#include "ips/output/output_sink.h"
#include "ips/output/packet_codec.h"

namespace ips {

class Publisher {
 public:
  /// Opens every output. Throws ips::InputError for a value that is not valid for its type,
  /// naming outputs[i]. `validate_only` (ipsd --check): outputs that would take something a
  /// running daemon holds or announce themselves on the network (a subscriptions listening port,
  /// a DDS participant) are not opened; the others are, which resolves and checks their addresses.
  explicit Publisher(const std::vector<OutputConfig>& outputs, bool validate_only = false);
  ~Publisher();
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  /// Sends one fused update (markers may be empty: a "nothing seen" heartbeat) to every output.
  void publish(const Datagram& update);

  std::vector<OutputStats> stats() const;

  /// Capture -> send latency of the last datagram sent by any output, ns.
  std::int64_t last_latency_ns() const { return last_latency_ns_; }

 private:
  std::vector<std::unique_ptr<OutputSink>> sinks_;
  std::int64_t last_latency_ns_ = 0;
};

}  // namespace ips
