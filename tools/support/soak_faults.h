// Faults and probes bench_soak applies to a running ipsd from outside: garbage at every port
// the daemon listens on, /proc figures of the process, the machine's load, and a spawn that
// is safe from a multi-threaded program. Header-only; used by tools/bench_soak.cpp only.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "loopback_udp.h"

extern char** environ;

namespace ips::soak {

/// posix_spawn with extra environment assignments and stdout+stderr appended to `log`: no
/// allocation between fork and exec, unlike a hand-written fork in a program with threads.
inline pid_t spawn_with_env(const std::vector<std::string>& argv, const std::vector<std::string>& extra_env,
                            const std::string& log) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) {
    const std::string kv = *e;
    bool replaced = false;
    for (const auto& x : extra_env)
      replaced = replaced || kv.substr(0, kv.find('=') + 1) == x.substr(0, x.find('=') + 1);
    if (!replaced) env.push_back(kv);
  }
  env.insert(env.end(), extra_env.begin(), extra_env.end());
  std::vector<char*> envp, args;
  for (auto& s : env) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_copy = argv;
  for (auto& s : argv_copy) args.push_back(s.data());
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

/// Figures of one process from /proc (NAN / -1 when it is gone).
struct ProcSample {
  double rss_kib = NAN;
  int threads = -1, fds = -1;
  long cpu_ticks = -1;  ///< utime + stime of the whole process, clock ticks
};

inline ProcSample proc_sample(pid_t pid) {
  ProcSample s;
  const std::filesystem::path base = std::filesystem::path("/proc") / std::to_string(pid);
  std::ifstream in(base / "status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("VmRSS:", 0) == 0) s.rss_kib = std::stod(line.substr(6));
    if (line.rfind("Threads:", 0) == 0) s.threads = std::stoi(line.substr(8));
  }
  std::ifstream stat_file(base / "stat");
  std::string stat;
  std::getline(stat_file, stat);
  if (const auto close = stat.rfind(')'); close != std::string::npos) {
    std::istringstream rest(stat.substr(close + 2));
    std::string field;
    long utime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stol(field);
      if (i == 15) s.cpu_ticks = utime + std::stol(field);
    }
  }
  std::error_code ec;
  int fds = 0;
  for (auto it = std::filesystem::directory_iterator(base / "fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
    ++fds;
  if (!ec) s.fds = fds;
  return s;
}

/// The 1-minute load average (/proc/loadavg).
inline double load_average_1m() {
  std::ifstream in("/proc/loadavg");
  double l = NAN;
  in >> l;
  return l;
}

inline std::vector<std::uint8_t> random_bytes(std::mt19937& rng, std::size_t max_len) {
  std::vector<std::uint8_t> b(std::uniform_int_distribution<std::size_t>(0, max_len)(rng));
  for (auto& x : b) x = static_cast<std::uint8_t>(rng());
  return b;
}

/// `count` datagrams of random bytes (0..1500; every 4th starts with the subscription
/// request's magic "IPSQ" so that it reaches deeper into the parser) to 127.0.0.1:port.
inline int udp_garbage(std::uint16_t port, int count, std::mt19937& rng) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  to.sin_port = htons(port);
  int sent = 0;
  for (int i = 0; i < count; ++i) {
    auto b = random_bytes(rng, 1500);
    if (i % 4 == 0 && b.size() >= 4) std::memcpy(b.data(), "IPSQ", 4);
    if (::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to) >= 0) ++sent;
    if (i % 100 == 99) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // a burst, not a flood test
  }
  ::close(fd);
  return sent;
}

inline int connect_tcp(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  to.sin_port = htons(port);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

inline int connect_unix(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

/// Reads what the peer sends within `ms` (until it closes), discarding it.
inline void drain(int fd, int ms) {
  char buf[4096];
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 20) != 1) continue;
    if (::recv(fd, buf, sizeof buf, MSG_DONTWAIT) <= 0) return;
  }
}

/// Stream-socket garbage: `count` connections each writing random bytes (and, for TCP, every
/// third a malformed HTTP request line), reading the answer briefly, closing; plus `idle`
/// connections held open without a byte for `hold_ms` (a client that connects and stalls).
/// `connect` opens one connection (-1 if refused). Returns the connections made.
template <class Connect>
inline int stream_garbage(Connect connect, int count, int idle, int hold_ms, bool http, std::mt19937& rng) {
  std::vector<int> held;
  for (int i = 0; i < idle; ++i)
    if (const int fd = connect(); fd >= 0) held.push_back(fd);
  int made = static_cast<int>(held.size());
  for (int i = 0; i < count; ++i) {
    const int fd = connect();
    if (fd < 0) continue;
    ++made;
    auto b = random_bytes(rng, 4096);
    if (http && i % 3 == 0) {
      const std::string junk =
          "GET /" + std::string(b.begin(), b.begin() + static_cast<long>(std::min<std::size_t>(b.size(), 200))) +
          " HTTP/1.1\r\nHost: x\r\nContent-Length: -5\r\n\r\n";
      b.assign(junk.begin(), junk.end());
    }
    (void)::send(fd, b.data(), b.size(), MSG_NOSIGNAL);
    drain(fd, 30);
    ::close(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(hold_ms));
  for (const int fd : held) ::close(fd);
  return made;
}

/// One plain HTTP GET; the status code of the answer (0 if none within 5 s).
inline int http_get_status(std::uint16_t port, const std::string& path) {
  const int fd = connect_tcp(port);
  if (fd < 0) return 0;
  const std::string req = "GET " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n";
  (void)::send(fd, req.data(), req.size(), MSG_NOSIGNAL);
  std::string answer;
  char buf[4096];
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (answer.size() < 16 && std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) != 1) continue;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    answer.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  int code = 0;
  if (answer.rfind("HTTP/1.", 0) == 0 && answer.size() >= 12) code = std::atoi(answer.c_str() + 9);
  return code;
}

/// A loopback port the kernel considers free right now (for the web and subscription ports).
inline std::uint16_t free_port(int type) { return support::free_loopback_port(type); }

}  // namespace ips::soak
