// Running the real programs from tests and benchmarks: start one with its output appended
// to a file, wait for it with a time limit, make sure it is gone at the end of a scope, and
// read the daemon's status socket. Header-only; shared by tests/ and tools/bench_*.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace ips::support {

/// Starts argv[0] with stdout+stderr appended to `log` and, if `stdin_fd` >= 0, that file
/// descriptor (e.g. the read end of a pipe a test types into) as its standard input.
/// Returns the pid.
inline pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& log, int stdin_fd = -1) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    if (stdin_fd >= 0) ::dup2(stdin_fd, 0);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return pid;
}

/// Waits up to `limit` for the child to exit and reaps it: its exit status, 128 + signal
/// if a signal ended it, -1 if it was reaped already; nullopt if it is still running.
inline std::optional<int> wait_exit(pid_t pid, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (true) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (r < 0 && errno == ECHILD) return -1;
    if (std::chrono::steady_clock::now() > end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

/// Kills (SIGKILL) and reaps a child that is still running when the scope ends, so that a
/// failed assertion never leaves a daemon behind.
struct ChildGuard {
  pid_t pid;
  explicit ChildGuard(pid_t p) : pid(p) {}
  ChildGuard(const ChildGuard&) = delete;
  ChildGuard& operator=(const ChildGuard&) = delete;
  ~ChildGuard() {
    if (pid > 0 && !wait_exit(pid, std::chrono::milliseconds(0))) {
      ::kill(pid, SIGKILL);
      (void)wait_exit(pid, std::chrono::seconds(5));
    }
  }
};

/// Runs to completion (at most `limit`, then killed); returns the exit status, -1 if killed.
inline int run(const std::vector<std::string>& argv, const std::filesystem::path& log,
               std::chrono::milliseconds limit = std::chrono::seconds(60)) {
  const pid_t pid = spawn(argv, log);
  if (const auto status = wait_exit(pid, limit)) return *status;
  ::kill(pid, SIGKILL);
  (void)wait_exit(pid, std::chrono::seconds(5));
  return -1;
}

/// Everything the daemon writes to a client of its unix status socket ("" if it is not there).
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

}  // namespace ips::support
