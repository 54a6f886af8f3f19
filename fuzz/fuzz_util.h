// Shared by the fuzz targets: a private scratch folder for the loaders that take a path, and
// the one exception a loader may throw for bad input (ips::InputError, which names the file
// and the place; anything else escaping is a finding: the daemon would die or say nothing useful).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace ips::fuzz {

/// A folder of this process's own (created once, removed at exit).
inline const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    std::string templ = (std::filesystem::temp_directory_path() / "ips-fuzz-XXXXXX").string();
    if (!::mkdtemp(templ.data())) std::abort();
    static const std::filesystem::path keep(templ);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(keep, ec);
    });
    return keep;
  }();
  return dir;
}

/// Writes `bytes` to `name` in the scratch folder and returns its path.
inline std::filesystem::path write_file(const std::string& name, std::string_view bytes) {
  const auto path = scratch() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) std::abort();
  return path;
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace ips::fuzz
