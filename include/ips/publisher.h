// Sends fused updates to every configured output (UDP unicast / broadcast / multicast), each in
// its own format. Sockets are non-blocking: a full send buffer or a network error is counted and
// logged (rate-limited), never fatal, and never stalls the caller.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ips/config.h"
#include "ips/packet_codec.h"

namespace ips {

struct OutputStats {
  std::string description;        ///< "unicast 127.0.0.1:5005 (binary)"
  std::uint64_t datagrams = 0;    ///< sent successfully
  std::uint64_t bytes = 0;
  std::uint64_t send_errors = 0;  ///< failed sendto (EAGAIN, unreachable, ...): datagram lost
};

class Publisher {
 public:
  /// Opens one socket per output. Throws ips::InputError for an address that is not valid for
  /// its kind (not IPv4 / not resolvable / not a multicast group), naming outputs[i].
  explicit Publisher(const std::vector<OutputConfig>& outputs);
  ~Publisher();
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  /// Sends one fused update (markers may be empty: a "nothing seen" heartbeat). Splits it into
  /// datagrams under IPS_WIRE_MAX_DATAGRAM bytes per output format, numbers them with each
  /// output's sequence counter, stamps the publish time just before each sendto.
  void publish(const Datagram& update);

  std::vector<OutputStats> stats() const;

  /// Capture -> sendto latency of the last datagram sent, ns (CLOCK_REALTIME difference).
  std::int64_t last_latency_ns() const { return last_latency_ns_; }

 private:
  struct Output;
  std::vector<std::unique_ptr<Output>> outputs_;
  std::int64_t last_latency_ns_ = 0;
};

}  // namespace ips
