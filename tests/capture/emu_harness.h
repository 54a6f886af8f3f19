// Runs a program under the V4L2 emulator (LD_PRELOAD) in a child process and collects its
// output. The preload must be in place at process start, hence the child.
#pragma once

#include <fcntl.h>
#include <link.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

extern char** environ;

namespace ips::test {

struct ChildResult {
  int status = -1;  ///< exit status, or 128 + signal
  std::string out, err;
};

/// A fresh directory under the system temp dir, removed at destruction.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("ips-capture-" + std::to_string(getpid()) + "-" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string str() const { return path_.string(); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

/// Path of the ASan runtime loaded into this process ("" in a build without ASan). A
/// sanitized child needs it first in LD_PRELOAD, before the emulator.
inline std::string loaded_asan_runtime() {
  std::string found;
  dl_iterate_phdr(
      [](dl_phdr_info* info, std::size_t, void* data) {
        if (info->dlpi_name && std::strstr(info->dlpi_name, "libasan.so"))
          *static_cast<std::string*>(data) = info->dlpi_name;
        return 0;
      },
      &found);
  return found;
}

/// Starts `argv` with the emulator preloaded, serving `devices` (fake path -> control file),
/// stdout to `out_path` and stderr to `err_path` (may be the same file). Returns the pid, or
/// -1 (errno set) if the program could not be started.
inline pid_t spawn_emulated(const std::vector<std::string>& argv, const std::map<std::string, std::string>& devices,
                            const std::string& out_path, const std::string& err_path) {
  std::string device_list;
  for (const auto& [path, control] : devices) device_list += (device_list.empty() ? "" : ",") + path + "=" + control;
  const std::string asan = loaded_asan_runtime();
  std::map<std::string, std::string> env_map;
  for (char** e = environ; *e; ++e) {
    const std::string kv = *e;
    const auto eq = kv.find('=');
    if (eq != std::string::npos) env_map[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  env_map["LD_PRELOAD"] = (asan.empty() ? "" : asan + ":") + IPS_V4L2_EMU_LIB;
  env_map["IPS_V4L2_EMU_DEVICES"] = device_list;
  if (!asan.empty()) {
    const std::string old = env_map.count("ASAN_OPTIONS") ? env_map["ASAN_OPTIONS"] + ":" : "";
    env_map["ASAN_OPTIONS"] = old + "verify_asan_link_order=0";
  }
  std::vector<std::string> env_strings;
  for (const auto& [k, v] : env_map) env_strings.push_back(k + "=" + v);
  std::vector<char*> envp, args;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_copy = argv;
  for (auto& s : argv_copy) args.push_back(s.data());
  args.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (err_path == out_path)
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
  else
    posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    errno = rc;
    return -1;
  }
  return pid;
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs `argv` with the emulator preloaded to completion and collects its output.
inline ChildResult run_emulated(const std::vector<std::string>& argv, const std::map<std::string, std::string>& devices,
                                const std::string& work_dir) {
  const std::string out_path = work_dir + "/child.out", err_path = work_dir + "/child.err";
  ChildResult result;
  const pid_t pid = spawn_emulated(argv, devices, out_path, err_path);
  if (pid < 0) {
    result.err = std::string("cannot start ") + argv[0] + ": " + std::strerror(errno);
    return result;
  }
  int wstatus = 0;
  waitpid(pid, &wstatus, 0);
  result.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  result.out = read_text(out_path);
  result.err = read_text(err_path);
  return result;
}

/// The value of `key=` in a line of `key=value` pairs ("" if absent). Values end at a space
/// except for the last key of a line, which takes the rest (error messages).
inline std::string field(const std::string& line, const std::string& key) {
  std::size_t pos = 0;
  while ((pos = line.find(key + "=", pos)) != std::string::npos) {
    if (pos == 0 || line[pos - 1] == ' ') break;
    ++pos;
  }
  if (pos == std::string::npos) return "";
  const std::size_t start = pos + key.size() + 1;
  const std::size_t next = line.find('=', start);
  if (next == std::string::npos) return line.substr(start);
  const std::size_t end = line.rfind(' ', next);
  return line.substr(start, end == std::string::npos || end < start ? std::string::npos : end - start);
}

inline std::vector<std::string> lines_starting(const std::string& text, const std::string& prefix) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(prefix, 0) == 0) out.push_back(line);
  return out;
}

}  // namespace ips::test
