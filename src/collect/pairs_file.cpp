// The pairs file of `ips collect`, held as placements so the last one can be undone and a
// file can be resumed.
#include <algorithm>
#include <sstream>

#include "ips/collect/collect.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"

namespace ips::collect {
namespace {
const std::string kHeader = "camera,xc,yc,zc,xw,yw,zw";
}  // namespace

PairsFile PairsFile::parse(const std::string& text, const std::string& name) {
  // The file is rewritten on every change, so only files in exactly this layout are resumed
  // (extra columns would be lost).
  std::istringstream lines(text);
  std::string header;
  while (std::getline(lines, header) && header.find_first_not_of(" \t\r") == std::string::npos) {
  }
  if (!header.empty() && header.back() == '\r') header.pop_back();
  if (header.find_first_not_of(" \t\r") == std::string::npos) return {};  // empty file
  if (header != kHeader)
    throw InputError(name + ": header is '" + header + "'; only files with the header '" + kHeader +
                     "' (as `ips collect` writes them) can be resumed");
  std::string row;
  bool any_row = false;
  while (!any_row && std::getline(lines, row)) any_row = row.find_first_not_of(" \t\r") != std::string::npos;
  if (!any_row) return {};
  std::istringstream in(text);
  const CalibData data = parse_calib_csv(in, name);  // validates and names file:line
  // Back to file order: (line, camera, cam, world) for every row.
  struct Row {
    std::size_t line;
    const std::string* camera;
    Eigen::Vector3d cam, world;
  };
  std::vector<Row> rows;
  for (const auto& set : data.cameras)
    for (std::size_t i = 0; i < set.cam.size(); ++i)
      rows.push_back({set.lines[i], &set.camera, set.cam[i], set.world[i]});
  std::sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.line < b.line; });
  PairsFile f;
  for (const Row& r : rows) {
    bool same = !f.placements_.empty() && f.placements_.back().world == r.world;
    if (same)
      for (const auto& [camera, p] : f.placements_.back().cameras) same = same && camera != *r.camera;
    if (!same) f.placements_.push_back({r.world, {}});
    f.placements_.back().cameras.emplace_back(*r.camera, r.cam);
  }
  return f;
}

bool PairsFile::undo(Placement& removed) {
  if (placements_.empty()) return false;
  removed = std::move(placements_.back());
  placements_.pop_back();
  return true;
}

std::map<std::string, int> PairsFile::counts() const {
  std::map<std::string, int> n;
  for (const auto& p : placements_)
    for (const auto& c : p.cameras) ++n[c.first];
  return n;
}

std::string PairsFile::text() const {
  std::ostringstream out;
  out.precision(9);
  out << kHeader << '\n';
  for (const auto& p : placements_)
    for (const auto& [camera, c] : p.cameras)
      out << camera << ',' << c.x() << ',' << c.y() << ',' << c.z() << ',' << p.world.x() << ',' << p.world.y() << ','
          << p.world.z() << '\n';
  return out.str();
}

}  // namespace ips::collect
