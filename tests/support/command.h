// Running a program from a test through the shell: its exit status and what it printed (the
// command line decides where stderr goes). For the command-line tools' tests.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace ips::test {

struct CommandResult {
  int status = -1;  ///< exit status; -1 if it could not run or did not exit normally
  std::string out;  ///< standard output
};

inline CommandResult run_shell(const std::string& command) {
  CommandResult r;
  FILE* p = ::popen(command.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), static_cast<int>(buf.size()), p) != nullptr) r.out += buf.data();
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

/// This build's `program` (e.g. "ips") with `args`; stderr into `out` too, or discarded.
inline CommandResult run_program(const std::string& program, const std::string& args, bool with_stderr = true) {
  return run_shell(std::string(IPS_BINARY_DIR) + "/" + program + " " + args + (with_stderr ? " 2>&1" : " 2>/dev/null"));
}

}  // namespace ips::test
