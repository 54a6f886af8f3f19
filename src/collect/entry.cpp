// What a line typed at the `ips collect` prompt means. Never throws: a typing error is
// answered with what was expected, and the prompt asks again.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ips/collect/collect.h"

namespace ips::collect {
namespace {

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

bool number(std::string_view text, double& value) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size() && std::isfinite(value);
}

// 'text' (built by appending: GCC 12 warns -Wrestrict on "literal" + std::string).
std::string quoted(std::string_view text) {
  std::string s(1, '\'');
  s.append(text);
  s += '\'';
  return s;
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

bool in_range(double v, double lo, double hi, const char* what, std::string& error) {
  if (v >= lo && v <= hi) return true;
  error = std::string(what) + " " + fmt(v) + " m is out of range (" + fmt(lo) + " .. " + fmt(hi) + " m)";
  return false;
}

const char* kPositionHelp = "type the world position as three numbers in metres, e.g. 1.20 0.85 0.00";

}  // namespace

bool parse_entry(std::string_view line, const EntryLimits& limits, Entry& out, std::string& error) {
  out = Entry{};
  error.clear();
  if (line.find(',') != std::string_view::npos) {
    error = "use spaces between the numbers, not commas: " + std::string(kPositionHelp);
    return false;
  }
  const auto w = words(line);
  if (w.empty()) {
    out.kind = Entry::Kind::kAccept;
    return true;
  }
  if (w.size() == 1) {
    const std::string_view c = w[0];
    const auto command = [&](Entry::Kind kind) {
      out.kind = kind;
      return true;
    };
    if (c == "u" || c == "undo") return command(Entry::Kind::kUndo);
    if (c == "s" || c == "skip") return command(Entry::Kind::kSkip);
    if (c == "q" || c == "quit") return command(Entry::Kind::kQuit);
    if (c == "?" || c == "h" || c == "help") return command(Entry::Kind::kHelp);
    double v = 0;
    if (!number(c, v)) {
      error = quoted(c) + " is neither a position nor a command (u, s, q, ?): " + kPositionHelp;
      return false;
    }
  }
  if (w[0] == "d") {
    // d DA DB Z [left|right]
    if (w.size() < 4 || w.size() > 5) {
      error =
          "distances: type d, the floor distances to A and B and the height, metres, "
          "optionally left or right, e.g. d 2.10 1.75 0.00 left";
      return false;
    }
    double v[3];
    for (int i = 0; i < 3; ++i) {
      if (!number(w[static_cast<std::size_t>(i) + 1], v[i])) {
        error = quoted(w[static_cast<std::size_t>(i) + 1]) + " is not a number: e.g. d 2.10 1.75 0.00 left";
        return false;
      }
    }
    if (!(v[0] > 0) || !(v[1] > 0)) {
      error = "a tape distance must be > 0 m";
      return false;
    }
    if (!in_range(v[0], 0, limits.max_distance, "distance to A", error) ||
        !in_range(v[1], 0, limits.max_distance, "distance to B", error) ||
        !in_range(v[2], limits.min_z, limits.max_z, "height", error))
      return false;
    out.kind = Entry::Kind::kDistances;
    out.d_a = v[0];
    out.d_b = v[1];
    out.z = v[2];
    if (w.size() == 5) {
      if (w[4] == "left" || w[4] == "l")
        out.side = Side::kLeft;
      else if (w[4] == "right" || w[4] == "r")
        out.side = Side::kRight;
      else {
        error = quoted(w[4]) + ": expected left or right (seen from A looking at B)";
        return false;
      }
    }
    return true;
  }
  if (w.size() != 3) {
    error = "expected 3 numbers, got " + std::to_string(w.size()) + " word(s): " + kPositionHelp;
    return false;
  }
  double v[3];
  for (int i = 0; i < 3; ++i) {
    if (!number(w[static_cast<std::size_t>(i)], v[i])) {
      error = quoted(w[static_cast<std::size_t>(i)]) + " is not a number: " + kPositionHelp;
      return false;
    }
  }
  if (!in_range(v[0], -limits.max_abs_xy, limits.max_abs_xy, "x", error) ||
      !in_range(v[1], -limits.max_abs_xy, limits.max_abs_xy, "y", error) ||
      !in_range(v[2], limits.min_z, limits.max_z, "z (height)", error))
    return false;
  out.kind = Entry::Kind::kPosition;
  out.position = {v[0], v[1], v[2]};
  return true;
}

}  // namespace ips::collect
