#include "udp_sink.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"

namespace ips {

namespace {
// At most one log line per output per this interval about send errors (with the count since).
}  // namespace

UdpSink::UdpSink(const OutputConfig& c, const std::string& where)
    : config_(c), last_error_log_ns_(-kSendErrorLogIntervalNs) {
  stats_.description = c.describe();
  to_.sin_family = AF_INET;
  to_.sin_port = htons(c.port);
  if (::inet_pton(AF_INET, c.address.c_str(), &to_.sin_addr) != 1) {
    if (c.kind != OutputConfig::Kind::kUnicast)
      throw InputError(where + ".address: '" + c.address + "' is not an IPv4 address");
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    addrinfo* res = nullptr;
    const int rc = ::getaddrinfo(c.address.c_str(), nullptr, &hints, &res);
    if (rc != 0 || !res)
      throw InputError(where + ".address: cannot resolve '" + c.address + "': " + ::gai_strerror(rc));
    to_.sin_addr = reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr;
    ::freeaddrinfo(res);
  }
  if (c.kind == OutputConfig::Kind::kMulticast && !IN_MULTICAST(ntohl(to_.sin_addr.s_addr)))
    throw InputError(where + ".address: '" + c.address + "' is not a multicast group (224.0.0.0/4)");

  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(where + ": socket: " + std::strerror(errno));
  try {
    if (c.kind == OutputConfig::Kind::kBroadcast) {
      const int on = 1;
      if (::setsockopt(fd_, SOL_SOCKET, SO_BROADCAST, &on, sizeof on) != 0)
        throw std::runtime_error(where + ": SO_BROADCAST: " + std::strerror(errno));
    }
    if (c.kind == OutputConfig::Kind::kMulticast) {
      const unsigned char ttl = static_cast<unsigned char>(c.ttl);
      if (::setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl) != 0)
        throw std::runtime_error(where + ": IP_MULTICAST_TTL: " + std::strerror(errno));
      if (!c.interface.empty()) {
        in_addr ifaddr{};
        if (::inet_pton(AF_INET, c.interface.c_str(), &ifaddr) != 1)
          throw InputError(where + ".interface: '" + c.interface + "' is not an IPv4 address");
        if (::setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_IF, &ifaddr, sizeof ifaddr) != 0)
          throw InputError(where + ".interface: " + c.interface + ": " + std::strerror(errno));
      }
    }
  } catch (...) {
    ::close(fd_);  // the destructor does not run for a constructor that throws
    throw;
  }
}

UdpSink::~UdpSink() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpSink::publish(const Datagram& update) {
  for (Datagram& d : split_update(update, config_.format)) {
    d.sequence = sequence_++;
    d.publish_realtime_ns = realtime_ns();
    const std::vector<std::uint8_t> bytes = encode(d, config_.format);
    const ssize_t n =
        ::sendto(fd_, bytes.data(), bytes.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&to_), sizeof to_);
    if (n == static_cast<ssize_t>(bytes.size())) {
      ++stats_.datagrams;
      stats_.bytes += bytes.size();
      last_latency_ns_ = d.publish_realtime_ns - d.capture_realtime_ns;
      continue;
    }
    const int err = errno;
    ++stats_.send_errors;
    ++errors_since_log_;
    const std::int64_t now = monotonic_ns();
    if (now - last_error_log_ns_ >= kSendErrorLogIntervalNs) {
      spdlog::warn("output {}: send failed: {} ({} datagram(s) lost since the last report)", stats_.description,
                   n < 0 ? std::strerror(err) : "short write", errors_since_log_);
      last_error_log_ns_ = now;
      errors_since_log_ = 0;
    }
  }
}

}  // namespace ips
