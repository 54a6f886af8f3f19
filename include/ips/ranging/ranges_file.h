#pragma once
// The files of `ips trilaterate` (docs/ranging.md has the formats):
//  - anchors.yaml: `anchors: [{id, x, y, z}]`, ids unique (a number or a word);
//  - ranges.csv: header `fix,reference,range` plus optional `sigma,ref_x,ref_y,ref_z,ref_sigma`,
//    one row per range; the rows of one fix need not be adjacent (fixes keep the order of their
//    first row). A reference not in anchors.yaml gives its position inline (ref_x, ref_y,
//    ref_z: a mobile reference, another robot); ref_sigma (m) is its position's uncertainty,
//    added to the range's sigma in quadrature;
//  - fixes.csv: `fix,x,y,z,cxx,cxy,cxz,cyy,cyz,czz,n,status`, one row per fix.
// Malformed input is an InputError naming file:line and the column.
#include <filesystem>
#include <istream>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/ranging/multilateration.h"

namespace ips {

using AnchorMap = std::map<std::string, Eigen::Vector3d>;

AnchorMap load_anchors_yaml(const std::filesystem::path& path);

struct RangeFixInput {
  std::string fix;  ///< the fix's name, as in the file
  std::vector<RangeToAnchor> ranges;
  std::size_t line = 0;  ///< its first row's line
};

/// `default_sigma` for rows without a sigma (m).
std::vector<RangeFixInput> parse_ranges_csv(std::istream& in, const std::string& name, const AnchorMap& anchors,
                                            double default_sigma = 0.1);

struct NamedFix {
  std::string fix;
  RangeFix result;
};

void write_fixes_csv(std::ostream& out, const std::vector<NamedFix>& fixes);
void write_fixes_json(std::ostream& out, const std::vector<NamedFix>& fixes);

}  // namespace ips
