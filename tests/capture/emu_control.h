// Writing the V4L2 emulator's control file (see v4l2_emulator.cpp for the keys), shared by
// the capture tests and their driver program.
#pragma once

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

namespace ips::test {

using EmuSettings = std::map<std::string, std::string>;

inline EmuSettings read_emu_control(const std::string& path) {
  std::ifstream in(path);
  EmuSettings settings;
  for (std::string line; std::getline(in, line);) {
    const auto eq = line.find('=');
    if (eq != std::string::npos) settings[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return settings;
}

/// Replaces the control file atomically (write + rename), so that the emulator never
/// reads a half-written file and notices the change (new inode).
inline void write_emu_control(const std::string& path, const EmuSettings& settings) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    for (const auto& [key, value] : settings) out << key << '=' << value << '\n';
    if (!out) throw std::runtime_error("cannot write " + tmp);
  }
  std::filesystem::rename(tmp, path);
}

inline void set_emu_control(const std::string& path, const std::string& key, const std::string& value) {
  EmuSettings settings = read_emu_control(path);
  settings[key] = value;
  write_emu_control(path, settings);
}

}  // namespace ips::test
