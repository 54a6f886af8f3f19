// Runs the independent MAVLink decoder (node-mavlink, tests/output/mavlink_decoder/decode.js,
// installed by tools/setup.sh with `npm ci`) on captured frames and returns its JSON.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace ips::test {

inline std::filesystem::path mavlink_decoder_dir() {
  return std::filesystem::path(IPS_SOURCE_DIR) / "tests" / "output" / "mavlink_decoder";
}

/// Why the decoder cannot run here ("" = it can). No node at all is a reason to skip; node
/// without the installed package is a setup error the caller should fail on.
inline std::string node_missing_reason() {
  if (std::system("command -v node >/dev/null 2>&1") != 0)
    return "node is not installed (tools/setup.sh installs nodejs): the independent MAVLink decoder cannot run";
  return "";
}

inline bool decoder_installed() {
  return std::filesystem::exists(mavlink_decoder_dir() / "node_modules" / "node-mavlink" / "package.json");
}

/// Writes `frames` (one per captured datagram, concatenated) to `scratch` and decodes them.
/// Returns the decoder's document, or nullopt with `error` set.
inline std::optional<nlohmann::json> decode_mavlink(const std::vector<std::vector<std::uint8_t>>& frames,
                                                    const std::filesystem::path& scratch, std::string& error) {
  {
    std::ofstream out(scratch, std::ios::binary);
    for (const auto& f : frames)
      out.write(reinterpret_cast<const char*>(f.data()), static_cast<std::streamsize>(f.size()));
  }
  const std::string cmd =
      "node '" + (mavlink_decoder_dir() / "decode.js").string() + "' '" + scratch.string() + "' 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) {
    error = "popen failed";
    return std::nullopt;
  }
  std::string text;
  char buf[65536];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) text.append(buf, n);
  const int rc = ::pclose(p);
  std::error_code ec;
  std::filesystem::remove(scratch, ec);
  if (rc != 0) {
    error = "decoder exited " + std::to_string(rc) + ": " + text;
    return std::nullopt;
  }
  try {
    return nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    error = std::string("decoder output is not JSON: ") + e.what() + ": " + text.substr(0, 500);
    return std::nullopt;
  }
}

/// A decoded float field: node prints NaN as the string "NaN".
inline double json_float(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>() == "NaN" ? std::nan("") : std::stod(v.get<std::string>());
  return v.get<double>();
}

}  // namespace ips::test
