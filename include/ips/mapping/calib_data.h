// Calibration data files: CSV pairs of camera coordinates and measured world coordinates.
//
// Format: a header line, then one row per pair. Required columns (any order):
//   camera,xc,yc,zc,xw,yw,zw     (camera name; camera coordinates; world coordinates; metres)
// Extra columns are allowed and ignored. Blank lines are skipped. Fields are separated by
// commas; surrounding spaces and a trailing CR are stripped; quoting is not supported.
#pragma once

#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ips {

/// Every pair of one camera, in file order.
struct CalibSet {
  std::string camera;
  std::vector<Eigen::Vector3d> cam;    ///< (xc, yc, zc), metres
  std::vector<Eigen::Vector3d> world;  ///< (xw, yw, zw), metres
  std::vector<std::size_t> lines;      ///< 1-based line of each pair in the file
};

struct CalibData {
  std::string source;             ///< file name used in messages
  std::vector<CalibSet> cameras;  ///< in order of first appearance in the file

  /// The camera's pairs, or nullptr.
  const CalibSet* find(const std::string& camera) const;
  /// "red, white, black" — for messages.
  std::string camera_list() const;
};

/// Reads and validates a calibration CSV. Throws ips::InputError naming the file, the line
/// and the column for: unreadable file, missing/duplicate column, wrong field count,
/// non-numeric or non-finite value, empty camera name, no data rows.
CalibData load_calib_csv(const std::filesystem::path& path);

/// Same, from a stream; `name` is used in messages.
CalibData parse_calib_csv(std::istream& in, const std::string& name);

}  // namespace ips
