#include "ips/ranging/ranges_file.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <set>
#include <string_view>

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include "core/map_reader.h"
#include "ips/core/csv_fields.h"
#include "ips/core/error.h"

namespace ips {
AnchorMap load_anchors_yaml(const std::filesystem::path& path, std::map<std::string, double>* biases) {
  const std::string file = path.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw InputError(file + ": cannot read the file");
  } catch (const YAML::Exception& e) {
    throw InputError(file + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  config_detail::MapReader top(root, "", file);
  const YAML::Node list = top.node("anchors");
  if (!list || !list.IsSequence() || list.size() == 0)
    throw InputError(file + ": 'anchors' must be a non-empty list of {id, x, y, z}");
  top.finish();
  AnchorMap anchors;
  for (std::size_t i = 0; i < list.size(); ++i) {
    config_detail::MapReader a(list[i], "anchors[" + std::to_string(i) + "]", file);
    std::string id;
    Eigen::Vector3d p;
    a.get("id", id, true);
    a.get("x", p.x(), true);
    a.get("y", p.y(), true);
    a.get("z", p.z(), true);
    double bias = 0.0;
    a.get("bias", bias, false);
    a.finish();
    if (std::abs(bias) > 10)
      throw InputError(file + ": anchors[" + std::to_string(i) + "].bias: " + std::to_string(bias) +
                       " m is not a bias");
    if (id.empty()) throw InputError(file + ": anchors[" + std::to_string(i) + "].id: empty");
    if (!anchors.emplace(id, p).second)
      throw InputError(file + ": anchors[" + std::to_string(i) + "].id: '" + id + "' is given twice");
    if (biases) (*biases)[id] = bias;
  }
  return anchors;
}

namespace {

using Columns = std::map<std::string, std::size_t, std::less<>>;

// The header (the first non-blank line): each column's index. `known` (if not empty) lists the
// columns allowed; `required` those that must be there. `line_no` is left at the header's line.
Columns read_header(std::istream& in, const std::string& name, std::size_t& line_no,
                    const std::set<std::string_view>& known, std::initializer_list<const char*> required,
                    const char* expected) {
  std::string line;
  Columns col;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim_csv_field(line).empty()) continue;
    const auto header = split_csv_line(line);
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (!known.empty() && !known.count(header[i])) {
        std::string columns;
        for (const std::string_view k : known) columns += (columns.empty() ? "" : ", ") + std::string(k);
        throw InputError(name + ":" + std::to_string(line_no) + ": unknown column '" + std::string(header[i]) +
                         "' (the columns: " + columns + ")");
      }
      if (!col.emplace(std::string(header[i]), i).second)
        throw InputError(name + ":" + std::to_string(line_no) + ": column '" + std::string(header[i]) + "' twice");
    }
    break;
  }
  if (col.empty()) throw InputError(name + ": empty file (expected the header " + expected + ")");
  for (const char* r : required)
    if (!col.count(r))
      throw InputError(name + ":" + std::to_string(line_no) + ": the header has no column '" + r + "'");
  return col;
}

}  // namespace

std::vector<RangeFixInput> parse_ranges_csv(std::istream& in, const std::string& name, const AnchorMap& anchors,
                                            double default_sigma) {
  static const std::set<std::string_view> kKnown = {"fix",   "reference", "range", "sigma",
                                                    "ref_x", "ref_y",     "ref_z", "ref_sigma"};
  std::string line;
  std::size_t line_no = 0;
  const Columns col = read_header(in, name, line_no, kKnown, {"fix", "reference", "range"}, "fix,reference,range");
  const bool inline_position = col.count("ref_x") || col.count("ref_y") || col.count("ref_z");
  if (inline_position && !(col.count("ref_x") && col.count("ref_y") && col.count("ref_z")))
    throw InputError(name + ":" + std::to_string(line_no) + ": ref_x, ref_y and ref_z come together");

  std::vector<RangeFixInput> fixes;
  std::map<std::string, std::size_t, std::less<>> index;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim_csv_field(line).empty()) continue;
    const std::string at = name + ":" + std::to_string(line_no);
    const auto f = split_csv_line(line);
    if (f.size() != col.size())
      throw InputError(at + ": " + std::to_string(f.size()) + " fields, the header has " + std::to_string(col.size()));
    const auto field = [&](const char* c) -> std::string_view { return f[col.at(c)]; };
    const auto optional_number = [&](const char* c) -> std::optional<double> {
      if (!col.count(c) || field(c).empty()) return std::nullopt;
      return parse_csv_number(field(c), at, "column '" + std::string(c) + "'");
    };
    const std::string fix(field("fix"));
    const std::string reference(field("reference"));
    if (fix.empty()) throw InputError(at + ": column 'fix': empty value");
    if (reference.empty()) throw InputError(at + ": column 'reference': empty value");
    RangeToAnchor r;
    r.range_m = parse_csv_number(field("range"), at, "column 'range'");
    if (r.range_m < 0) throw InputError(at + ": column 'range': negative");
    r.sigma_m = optional_number("sigma").value_or(default_sigma);
    if (!(r.sigma_m > 0)) throw InputError(at + ": column 'sigma': must be > 0");
    const auto rx = optional_number("ref_x"), ry = optional_number("ref_y"), rz = optional_number("ref_z");
    std::string anchor_id;
    if (rx || ry || rz) {
      if (!(rx && ry && rz)) throw InputError(at + ": ref_x, ref_y and ref_z are given together or not at all");
      r.anchor = {*rx, *ry, *rz};
    } else if (const auto it = anchors.find(reference); it != anchors.end()) {
      r.anchor = it->second;
      anchor_id = reference;
    } else {
      throw InputError(at + ": reference '" + reference +
                       "' is not in the anchors file and has no inline position (ref_x, ref_y, ref_z)");
    }
    if (const auto ref_sigma = optional_number("ref_sigma")) {
      if (*ref_sigma < 0) throw InputError(at + ": column 'ref_sigma': negative");
      r.sigma_m = std::hypot(r.sigma_m, *ref_sigma);
    }
    auto [it, fresh] = index.emplace(fix, fixes.size());
    if (fresh) fixes.push_back({fix, {}, {}, line_no});
    fixes[it->second].ranges.push_back(r);
    fixes[it->second].anchors.push_back(anchor_id);
  }
  return fixes;
}

std::map<std::string, KnownPosition> parse_positions_csv(std::istream& in, const std::string& name) {
  std::string line;
  std::size_t line_no = 0;
  const Columns col = read_header(in, name, line_no, {}, {"fix", "x", "y", "z"}, "fix,x,y,z");
  std::map<std::string, KnownPosition> out;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim_csv_field(line).empty()) continue;
    const std::string at = name + ":" + std::to_string(line_no);
    const auto f = split_csv_line(line);
    if (f.size() != col.size())
      throw InputError(at + ": " + std::to_string(f.size()) + " fields, the header has " + std::to_string(col.size()));
    const auto number = [&](const char* c) {
      return parse_csv_number(f[col.at(c)], at, "column '" + std::string(c) + "'");
    };
    const std::string fix(f[col.at("fix")]);
    if (fix.empty()) throw InputError(at + ": column 'fix': empty value");
    KnownPosition p;
    p.position = {number("x"), number("y"), number("z")};
    if (col.count("sigma") && !f[col.at("sigma")].empty()) {
      p.sigma_m = number("sigma");
      if (*p.sigma_m < 0) throw InputError(at + ": column 'sigma': negative");
    }
    if (!out.emplace(fix, p).second) throw InputError(at + ": fix '" + fix + "' is given twice");
  }
  return out;
}

void write_fixes_csv(std::ostream& out, const std::vector<NamedFix>& fixes) {
  out << "fix,x,y,z,cxx,cxy,cxz,cyy,cyz,czz,n,status\n";
  char buf[512];
  for (const auto& [name, f] : fixes) {
    out << name;
    if (f.ok) {
      const Eigen::Matrix3d& c = f.covariance;
      std::snprintf(buf, sizeof buf, ",%.6f,%.6f,%.6f,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,ok\n", f.position.x(),
                    f.position.y(), f.position.z(), c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2),
                    f.ranges_used);
    } else {
      std::snprintf(buf, sizeof buf, ",,,,,,,,,,%d,%s\n", f.ranges_used, range_fix_status_word(f.status));
    }
    out << buf;
  }
}

void write_fixes_json(std::ostream& out, const std::vector<NamedFix>& fixes) {
  nlohmann::json all = nlohmann::json::array();
  for (const auto& [name, f] : fixes) {
    nlohmann::json j = {{"fix", name}, {"n", f.ranges_used}, {"status", range_fix_status_word(f.status)}};
    if (f.ok) {
      j["position"] = {f.position.x(), f.position.y(), f.position.z()};
      const Eigen::Matrix3d& c = f.covariance;
      j["covariance"] = {{c(0, 0), c(0, 1), c(0, 2)}, {c(1, 0), c(1, 1), c(1, 2)}, {c(2, 0), c(2, 1), c(2, 2)}};
      j["rms_residual_m"] = f.rms_residual_m;
    } else {
      j["why"] = f.why;
    }
    all.push_back(std::move(j));
  }
  out << all.dump(2) << "\n";
}

}  // namespace ips
