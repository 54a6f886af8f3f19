#include "ips/publisher.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <spdlog/spdlog.h>

#include "ips/clock.h"
#include "ips/error.h"

namespace ips {

namespace {
// At most one log line per output per this interval about send errors (with the count since).
constexpr std::int64_t kErrorLogIntervalNs = 10'000'000'000;
}  // namespace

struct Publisher::Output {
  OutputConfig config;
  int fd = -1;
  sockaddr_in to{};
  std::uint32_t sequence = 0;
  OutputStats stats;
  std::int64_t last_error_log_ns = -kErrorLogIntervalNs;
  std::uint64_t errors_since_log = 0;

  ~Output() {
    if (fd >= 0) ::close(fd);
  }
};

Publisher::Publisher(const std::vector<OutputConfig>& outputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const OutputConfig& c = outputs[i];
    const std::string where = "outputs[" + std::to_string(i) + "]";
    auto out = std::make_unique<Output>();
    out->config = c;
    out->stats.description = c.describe();
    out->to.sin_family = AF_INET;
    out->to.sin_port = htons(c.port);
    if (::inet_pton(AF_INET, c.address.c_str(), &out->to.sin_addr) != 1) {
      if (c.kind != OutputConfig::Kind::kUnicast)
        throw InputError(where + ".address: '" + c.address + "' is not an IPv4 address");
      addrinfo hints{};
      hints.ai_family = AF_INET;
      hints.ai_socktype = SOCK_DGRAM;
      addrinfo* res = nullptr;
      const int rc = ::getaddrinfo(c.address.c_str(), nullptr, &hints, &res);
      if (rc != 0 || !res)
        throw InputError(where + ".address: cannot resolve '" + c.address + "': " + ::gai_strerror(rc));
      out->to.sin_addr = reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr;
      ::freeaddrinfo(res);
    }
    if (c.kind == OutputConfig::Kind::kMulticast && !IN_MULTICAST(ntohl(out->to.sin_addr.s_addr)))
      throw InputError(where + ".address: '" + c.address + "' is not a multicast group (224.0.0.0/4)");

    out->fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (out->fd < 0) throw std::runtime_error(where + ": socket: " + std::strerror(errno));
    if (c.kind == OutputConfig::Kind::kBroadcast) {
      const int on = 1;
      if (::setsockopt(out->fd, SOL_SOCKET, SO_BROADCAST, &on, sizeof on) != 0)
        throw std::runtime_error(where + ": SO_BROADCAST: " + std::strerror(errno));
    }
    if (c.kind == OutputConfig::Kind::kMulticast) {
      const unsigned char ttl = static_cast<unsigned char>(c.ttl);
      if (::setsockopt(out->fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl) != 0)
        throw std::runtime_error(where + ": IP_MULTICAST_TTL: " + std::strerror(errno));
      if (!c.interface.empty()) {
        in_addr ifaddr{};
        if (::inet_pton(AF_INET, c.interface.c_str(), &ifaddr) != 1)
          throw InputError(where + ".interface: '" + c.interface + "' is not an IPv4 address");
        if (::setsockopt(out->fd, IPPROTO_IP, IP_MULTICAST_IF, &ifaddr, sizeof ifaddr) != 0)
          throw InputError(where + ".interface: " + c.interface + ": " + std::strerror(errno));
      }
    }
    outputs_.push_back(std::move(out));
  }
}

Publisher::~Publisher() = default;

void Publisher::publish(const Datagram& update) {
  for (auto& out : outputs_) {
    for (Datagram& d : split_update(update, out->config.format)) {
      d.sequence = out->sequence++;
      d.publish_realtime_ns = realtime_ns();
      const std::vector<std::uint8_t> bytes = encode(d, out->config.format);
      const ssize_t n = ::sendto(out->fd, bytes.data(), bytes.size(), MSG_DONTWAIT,
                                 reinterpret_cast<const sockaddr*>(&out->to), sizeof out->to);
      if (n == static_cast<ssize_t>(bytes.size())) {
        ++out->stats.datagrams;
        out->stats.bytes += bytes.size();
        last_latency_ns_ = d.publish_realtime_ns - d.capture_realtime_ns;
        continue;
      }
      const int err = errno;
      ++out->stats.send_errors;
      ++out->errors_since_log;
      const std::int64_t now = monotonic_ns();
      if (now - out->last_error_log_ns >= kErrorLogIntervalNs) {
        spdlog::warn("output {}: send failed: {} ({} datagram(s) lost since the last report)",
                     out->stats.description, n < 0 ? std::strerror(err) : "short write", out->errors_since_log);
        out->last_error_log_ns = now;
        out->errors_since_log = 0;
      }
    }
  }
}

std::vector<OutputStats> Publisher::stats() const {
  std::vector<OutputStats> s;
  for (const auto& out : outputs_) s.push_back(out->stats);
  return s;
}

}  // namespace ips
