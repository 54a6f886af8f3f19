#include "ros2_names.h"

#include <cmath>

namespace ips::ros2 {

namespace {
bool alpha(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool digit(char c) { return c >= '0' && c <= '9'; }

void replace_all(std::string& s, std::string_view what, const std::string& with) {
  for (auto at = s.find(what); at != std::string::npos; at = s.find(what, at + with.size()))
    s.replace(at, what.size(), with);
}
}  // namespace

bool is_name_token(std::string_view s) {
  if (s.empty() || !alpha(s[0])) return false;
  for (char c : s)
    if (!alpha(c) && !digit(c)) return false;
  return true;
}

bool is_namespace(std::string_view s) {
  if (s.empty()) return false;
  while (true) {
    const auto slash = s.find('/');
    if (!is_name_token(s.substr(0, slash))) return false;
    if (slash == std::string_view::npos) return true;
    s.remove_prefix(slash + 1);
  }
}

std::string marker_name(const Ros2OutputSettings& s, std::uint32_t id) {
  const auto it = s.marker_names.find(static_cast<int>(id));
  if (it != s.marker_names.end() && !it->second.empty()) return it->second;
  return "marker_" + std::to_string(id);
}

std::string child_frame(const Ros2OutputSettings& s, std::uint32_t id) {
  std::string f = s.child_frame_id;
  replace_all(f, "{name}", marker_name(s, id));
  replace_all(f, "{id}", std::to_string(id));
  return f;
}

std::string marker_topic(const Ros2OutputSettings& s, std::uint32_t id, std::string_view leaf) {
  return "rt/" + s.prefix + "/" + marker_name(s, id) + "/" + std::string(leaf);
}

std::string body_topic(const Ros2OutputSettings& s, const std::string& body, std::string_view leaf) {
  return "rt/" + s.prefix + "/" + body + "/" + std::string(leaf);
}

std::string body_child_frame(const Ros2OutputSettings& s, const std::string& body) {
  std::string f = s.child_frame_id;
  replace_all(f, "{name}", body);
  replace_all(f, "{id}", body);
  return f;
}

Stamp to_stamp(std::int64_t realtime_ns) {
  // Floor division: a (theoretical) instant before 1970 still gets nanosec in 0..1e9.
  std::int64_t sec = realtime_ns / 1'000'000'000;
  std::int64_t ns = realtime_ns % 1'000'000'000;
  if (ns < 0) {
    ns += 1'000'000'000;
    --sec;
  }
  return {static_cast<std::int32_t>(sec), static_cast<std::uint32_t>(ns)};
}

Quaternion yaw_quaternion(double yaw) { return {0.0, 0.0, std::sin(yaw / 2), std::cos(yaw / 2)}; }

}  // namespace ips::ros2
