// The list of placements prepared in advance for `ips collect --points`.
#include <charconv>
#include <cmath>
#include <sstream>

#include "ips/collect/collect.h"
#include "ips/core/error.h"

namespace ips::collect {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  while (true) {
    const auto comma = line.find(',');
    out.push_back(trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) return out;
    line.remove_prefix(comma + 1);
  }
}

}  // namespace

std::vector<Eigen::Vector3d> parse_points_csv(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string line;
  std::size_t line_no = 0;
  std::vector<std::string_view> header;
  std::string header_line;
  while (header.empty() && std::getline(in, header_line)) {
    ++line_no;
    if (!trim(header_line).empty()) header = split(header_line);
  }
  if (header.empty()) throw InputError(name + ": empty file (expected a header line 'xw,yw,zw')");
  const std::size_t header_no = line_no;
  int col[3] = {-1, -1, -1};
  const char* names[3] = {"xw", "yw", "zw"};
  for (std::size_t i = 0; i < header.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (header[i] == names[k]) col[k] = static_cast<int>(i);
  for (int k = 0; k < 3; ++k)
    if (col[k] < 0)
      throw InputError(name + ":" + std::to_string(header_no) + ": missing column '" + names[k] +
                       "' (header must name xw,yw,zw)");
  std::vector<Eigen::Vector3d> points;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim(line).empty()) continue;
    const auto fields = split(line);
    const std::string at = name + ":" + std::to_string(line_no);
    if (fields.size() != header.size())
      throw InputError(at + ": " + std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(header.size()));
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) {
      std::string_view f = fields[static_cast<std::size_t>(col[k])];
      if (!f.empty() && f.front() == '+') f.remove_prefix(1);
      double v = 0;
      const auto [end, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
      if (ec != std::errc() || end != f.data() + f.size() || !std::isfinite(v) || f.empty())
        throw InputError(at + ": column '" + names[k] + "': '" + std::string(fields[static_cast<std::size_t>(col[k])]) +
                         "' is not a number");
      p[k] = v;
    }
    points.push_back(p);
  }
  if (points.empty()) throw InputError(name + ": no positions after the header");
  return points;
}

}  // namespace ips::collect
