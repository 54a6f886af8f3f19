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
#include "loopback_udp.h"

namespace ips::test {

using support::ChildGuard;
using support::read_unix_socket;
using support::run;
using support::spawn;
using support::UdpReceiver;
using support::wait_exit;

// Sanitizer builds run the daemon (rendering, detection) several times slower: wait longer.
// GCC defines __SANITIZE_ADDRESS__; clang (14) only answers __has_feature.
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define IPS_TEST_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__) || defined(IPS_TEST_SANITIZED)
constexpr double kTimeScale = 6.0;
#else
constexpr double kTimeScale = 1.0;
#endif

inline std::string bin(const std::string& name) { return std::string(IPS_BINARY_DIR) + "/" + name; }

/// The whole file as text ("" if it cannot be read).
inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A free UDP port on 127.0.0.1 (bound and released: another process could take it in
/// between, which is unlikely enough for tests).
inline std::uint16_t free_udp_port() {
  UdpReceiver r;
  return r.port;
}

}  // namespace ips::test
