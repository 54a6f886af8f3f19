#pragma once
// The files of `ips trilaterate` and `ips ranging calibrate` (docs/ranging.md has the formats):
//  - anchors.yaml: `anchors: [{id, x, y, z, bias}]`, ids unique (a number or a word); `bias`
//    (m, optional, default 0): the anchor's module reads that much long (subtracted first);
//  - ranges.csv: header `fix,reference,range` plus optional `sigma,ref_x,ref_y,ref_z,ref_sigma`,
//    one row per range; the rows of one fix need not be adjacent (fixes keep the order of their
//    first row). A reference not in anchors.yaml gives its position inline (ref_x, ref_y,
//    ref_z: a mobile reference, another robot); ref_sigma (m) is its position's uncertainty,
//    added to the range's sigma in quadrature;
//  - fixes.csv: `fix,x,y,z,cxx,cxy,cxz,cyy,cyz,czz,n,status`, one row per fix;
//  - positions.csv: `fix,x,y,z` plus optional `sigma` (m), where the tag was at each fix
//    (measured another way); other columns are ignored, so a truth file of `ips sim ranges`
//    is one.
// Malformed input is an InputError naming file:line and the column.
#include <filesystem>
#include <istream>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/ranging/multilateration.h"

namespace ips {

using AnchorMap = std::map<std::string, Eigen::Vector3d>;

/// `biases` (if given) receives each anchor's `bias` (0 where absent).
AnchorMap load_anchors_yaml(const std::filesystem::path& path, std::map<std::string, double>* biases = nullptr);

struct RangeFixInput {
  std::string fix;  ///< the fix's name, as in the file
  std::vector<RangeToAnchor> ranges;
  /// Per range: the anchor's id, or "" for a reference with an inline position.
  std::vector<std::string> anchors;
  std::size_t line = 0;  ///< its first row's line
};

/// `default_sigma` for rows without a sigma (m).
std::vector<RangeFixInput> parse_ranges_csv(std::istream& in, const std::string& name, const AnchorMap& anchors,
                                            double default_sigma = 0.1);

struct KnownPosition {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::optional<double> sigma_m;  ///< its 1-sigma, if the file says
};
/// positions.csv by fix name. Duplicate fixes, missing columns, bad numbers: InputError at file:line.
std::map<std::string, KnownPosition> parse_positions_csv(std::istream& in, const std::string& name);

struct NamedFix {
  std::string fix;
  RangeFix result;
};

void write_fixes_csv(std::ostream& out, const std::vector<NamedFix>& fixes);
void write_fixes_json(std::ostream& out, const std::vector<NamedFix>& fixes);

}  // namespace ips
