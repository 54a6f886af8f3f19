// Helpers for tests that run the real programs: the programs' paths, sanitizer time scale,
// UDP receive on a kernel-chosen loopback port, plus the process helpers shared with the
// benchmarks (tools/support/child_process.h).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.h"

namespace ips::test {

using support::ChildGuard;
using support::read_unix_socket;
using support::run;
using support::spawn;
using support::wait_exit;

// Sanitizer builds run the daemon (rendering, detection) several times slower: wait longer.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr double kTimeScale = 6.0;
#else
constexpr double kTimeScale = 1.0;
#endif

inline std::string bin(const std::string& name) { return std::string(IPS_BINARY_DIR) + "/" + name; }

/// Waits up to `limit` for the process; returns its exit status, or nullopt if still running.
inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A UDP socket bound to 127.0.0.1 on a free port chosen by the kernel.
struct UdpReceiver {
  int fd = -1;
  std::uint16_t port = 0;
  UdpReceiver() {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    const int rcvbuf = 4 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~UdpReceiver() { ::close(fd); }
  /// One datagram within `timeout_ms`, or nullopt.
  std::optional<std::vector<std::uint8_t>> receive(int timeout_ms) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) != 1) return std::nullopt;
    std::vector<std::uint8_t> buf(65536);
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n < 0) return std::nullopt;
    buf.resize(static_cast<std::size_t>(n));
    return buf;
  }
};

/// A free UDP port on 127.0.0.1 (bound and released: another process could take it in
/// between, which is unlikely enough for tests).
inline std::uint16_t free_udp_port() {
  UdpReceiver r;
  return r.port;
}

}  // namespace ips::test
