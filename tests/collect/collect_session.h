// Plays the user of an `ips collect` session: types lines into its standard input (a pipe)
// and waits for its prompts in its output log. Header-only, for the collect tests.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "process_util.h"

namespace ips::test {

class CollectSession {
 public:
  CollectSession(const std::vector<std::string>& argv, const std::filesystem::path& log) : log_(log) {
    ::signal(SIGPIPE, SIG_IGN);  // a session that ended must fail the test, not kill it
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return;
    pid_ = spawn(argv, log, fds[0]);
    ::close(fds[0]);
    input_ = fds[1];
  }
  CollectSession(const CollectSession&) = delete;
  CollectSession& operator=(const CollectSession&) = delete;
  ~CollectSession() {
    end_input();
    const ChildGuard guard(pid_);
  }

  /// Types one line (Enter included).
  void type(const std::string& line) {
    const std::string text = line + "\n";
    if (input_ >= 0) (void)!::write(input_, text.data(), text.size());
  }
  /// Ctrl-D: the session ends at its next prompt.
  void end_input() {
    if (input_ >= 0) ::close(input_);
    input_ = -1;
  }
  std::string output() const { return read_file(log_); }
  /// How many prompts the session has shown ("placement N: ..." at a line start).
  int prompts() const {
    const std::string text = output();
    int n = 0;
    for (std::size_t at = 0; (at = text.find("placement ", at)) != std::string::npos; at += 10)
      n += (at == 0 || text[at - 1] == '\n') && text.find(": ", at) < text.find('\n', at);
    return n;
  }
  /// Waits (up to `seconds`, scaled for the sanitizers) for prompt number `n`.
  bool wait_prompt(int n, double seconds = 60) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds * kTimeScale);
    while (std::chrono::steady_clock::now() < end) {
      if (prompts() >= n) return true;
      if (exited(std::chrono::milliseconds(0))) return prompts() >= n;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
  /// Ends the input and waits for the exit status (nullopt: still running after `seconds`).
  std::optional<int> finish(double seconds = 30) {
    end_input();
    return exited(std::chrono::milliseconds(static_cast<long>(seconds * kTimeScale * 1000)));
  }

 private:
  // The exit status once the session has ended (reaped once, remembered).
  std::optional<int> exited(std::chrono::milliseconds limit) const {
    if (!status_ && pid_ > 0) status_ = wait_exit(pid_, limit);
    return pid_ > 0 ? status_ : std::optional<int>(-1);
  }

  std::filesystem::path log_;
  pid_t pid_ = -1;
  int input_ = -1;
  mutable std::optional<int> status_;
};

/// Writes `text` to `path` through a rename, so the simulator never reads half a file.
inline void write_atomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  std::ofstream(tmp) << text;
  std::filesystem::rename(tmp, path);
}

}  // namespace ips::test
