// Helpers for tests that run the real programs: spawn with output to a file, wait with a
// time limit, UDP receive on a kernel-chosen loopback port, read the daemon's status socket.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace ips::test {

// Sanitizer builds run the daemon (rendering, detection) several times slower: wait longer.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr double kTimeScale = 6.0;
#else
constexpr double kTimeScale = 1.0;
#endif

inline std::string bin(const std::string& name) { return std::string(IPS_BINARY_DIR) + "/" + name; }

/// Starts argv[0] with stdout+stderr appended to `log`. Returns the pid.
inline pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return pid;
}

/// Waits up to `limit` for the process; returns its exit status, or nullopt if still running.
inline std::optional<int> wait_exit(pid_t pid, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (true) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (std::chrono::steady_clock::now() > end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

/// Kills (SIGKILL) and reaps a child that is still running when the scope ends, so that a
/// failed assertion never leaves a daemon behind.
struct ChildGuard {
  pid_t pid;
  explicit ChildGuard(pid_t p) : pid(p) {}
  ~ChildGuard() {
    if (pid > 0 && !wait_exit(pid, std::chrono::milliseconds(0))) {
      ::kill(pid, SIGKILL);
      (void)wait_exit(pid, std::chrono::seconds(5));
    }
  }
};

/// Runs to completion (at most `limit`, then killed); returns the exit status.
inline int run(const std::vector<std::string>& argv, const std::filesystem::path& log,
               std::chrono::milliseconds limit = std::chrono::seconds(60)) {
  const pid_t pid = spawn(argv, log);
  auto status = wait_exit(pid, limit);
  if (!status) {
    ::kill(pid, SIGKILL);
    status = wait_exit(pid, std::chrono::seconds(5));
    return -1;
  }
  return *status;
}

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

inline std::string read_unix_socket(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  std::string text;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    char buf[4096];
    ssize_t n;
    while ((n = ::read(fd, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return text;
}

}  // namespace ips::test
