// unicast | broadcast | multicast outputs: ipsd's own datagrams (include/ips/output/wire.h) over UDP,
// one non-blocking socket per output, split under IPS_WIRE_MAX_DATAGRAM, numbered per output.
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <string>

#include "ips/core/error.h"
#include "ips/output/output_sink.h"

namespace ips {

class UdpSink final : public OutputSink {
 public:
  /// `where` = "outputs[i]" for error messages.
  UdpSink(const OutputConfig& config, const std::string& where);
  ~UdpSink() override;
  UdpSink(const UdpSink&) = delete;
  UdpSink& operator=(const UdpSink&) = delete;

  void publish(const Datagram& update) override;
  OutputStats stats() const override { return stats_; }
  std::int64_t last_latency_ns() const override { return last_latency_ns_; }

 private:
  OutputConfig config_;
  int fd_ = -1;
  sockaddr_in to_{};
  std::uint32_t sequence_ = 0;
  OutputStats stats_;
  std::int64_t last_error_log_ns_;
  std::uint64_t errors_since_log_ = 0;
  std::int64_t last_latency_ns_ = 0;
};

}  // namespace ips
