// CSV loader for calibration pairs (format documented in include/ips/mapping/calib_data.h).
#include "ips/mapping/calib_data.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <istream>
#include <map>
#include <string_view>

#include "ips/core/error.h"

namespace ips {
namespace {

constexpr std::array<std::string_view, 7> kRequired = {"camera", "xc", "yc", "zc", "xw", "yw", "zw"};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      fields.push_back(trim(line.substr(start)));
      return fields;
    }
    fields.push_back(trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
}

std::string where(const std::string& name, std::size_t line) { return name + ":" + std::to_string(line); }

double parse_number(std::string_view text, const std::string& at, std::string_view column, std::size_t column_index) {
  const std::string col = "column '" + std::string(column) + "' (" + std::to_string(column_index + 1) + ")";
  if (text.empty()) throw InputError(at + ": " + col + ": empty value");
  std::string_view digits = text;
  if (digits.front() == '+') digits.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range)
    throw InputError(at + ": " + col + ": value '" + std::string(text) + "' is out of range");
  if (ec != std::errc() || end != digits.data() + digits.size())
    throw InputError(at + ": " + col + ": '" + std::string(text) + "' is not a number");
  if (!std::isfinite(value)) throw InputError(at + ": " + col + ": '" + std::string(text) + "' is not a finite number");
  return value;
}

}  // namespace

const CalibSet* CalibData::find(const std::string& camera) const {
  for (const auto& set : cameras)
    if (set.camera == camera) return &set;
  return nullptr;
}

std::string CalibData::camera_list() const {
  std::string list;
  for (const auto& set : cameras) list += (list.empty() ? "" : ", ") + set.camera;
  return list;
}

CalibData parse_calib_csv(std::istream& in, const std::string& name) {
  CalibData data;
  data.source = name;
  std::string line;
  std::size_t line_no = 0;

  // Header: the first non-blank line.
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim(line).empty()) continue;
    for (auto field : split(line)) header.emplace_back(field);
    break;
  }
  if (header.empty()) throw InputError(name + ": empty file (expected a header line " + "'camera,xc,yc,zc,xw,yw,zw')");
  const std::size_t header_line = line_no;
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i].empty()) continue;  // an unnamed extra column is ignored
    if (!index.emplace(header[i], i).second)
      throw InputError(where(name, header_line) + ": column '" + header[i] + "' appears twice");
  }
  std::array<std::size_t, kRequired.size()> col{};
  for (std::size_t k = 0; k < kRequired.size(); ++k) {
    const auto it = index.find(std::string(kRequired[k]));
    if (it == index.end())
      throw InputError(where(name, header_line) + ": missing required column '" + std::string(kRequired[k]) +
                       "' (header must name camera,xc,yc,zc,xw,yw,zw)");
    col[k] = it->second;
  }

  std::map<std::string, std::size_t> set_of;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim(line).empty()) continue;
    const auto fields = split(line);
    const std::string at = where(name, line_no);
    if (fields.size() != header.size())
      throw InputError(at + ": " + std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(header.size()));
    const std::string camera(fields[col[0]]);
    if (camera.empty())
      throw InputError(at + ": column 'camera' (" + std::to_string(col[0] + 1) + "): empty camera name");
    std::array<double, 6> v{};
    for (std::size_t k = 1; k < kRequired.size(); ++k)
      v[k - 1] = parse_number(fields[col[k]], at, kRequired[k], col[k]);
    auto [it, inserted] = set_of.emplace(camera, data.cameras.size());
    if (inserted) data.cameras.push_back(CalibSet{camera, {}, {}, {}});
    CalibSet& set = data.cameras[it->second];
    set.cam.emplace_back(v[0], v[1], v[2]);
    set.world.emplace_back(v[3], v[4], v[5]);
    set.lines.push_back(line_no);
  }
  if (in.bad()) throw InputError(name + ": read error");
  if (data.cameras.empty()) throw InputError(name + ": no data rows after the header");
  return data;
}

CalibData load_calib_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open calibration data file");
  return parse_calib_csv(in, path.string());
}

}  // namespace ips
