// CSV loader for calibration pairs (format documented in include/ips/mapping/calib_data.h).
#include "ips/mapping/calib_data.h"

#include <array>
#include <fstream>
#include <istream>
#include <map>
#include <string_view>

#include "ips/core/csv_fields.h"
#include "ips/core/error.h"

namespace ips {
namespace {

constexpr std::array<std::string_view, 7> kRequired = {"camera", "xc", "yc", "zc", "xw", "yw", "zw"};

std::string where(const std::string& name, std::size_t line) { return name + ":" + std::to_string(line); }

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
    if (trim_csv_field(line).empty()) continue;
    for (auto field : split_csv_line(line)) header.emplace_back(field);
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
    if (trim_csv_field(line).empty()) continue;
    const auto fields = split_csv_line(line);
    const std::string at = where(name, line_no);
    if (fields.size() != header.size())
      throw InputError(at + ": " + std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(header.size()));
    const std::string camera(fields[col[0]]);
    if (camera.empty())
      throw InputError(at + ": column 'camera' (" + std::to_string(col[0] + 1) + "): empty camera name");
    std::array<double, 6> v{};
    for (std::size_t k = 1; k < kRequired.size(); ++k)
      v[k - 1] = parse_csv_number(fields[col[k]], at,
                                  "column '" + std::string(kRequired[k]) + "' (" + std::to_string(col[k] + 1) + ")");
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
