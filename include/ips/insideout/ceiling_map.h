// A map of markers fixed on the ceiling, read by a camera that rides on a robot and looks up
// (inside-out localisation, docs/inside-out.md). Every marker is printed face down on the
// ceiling plane: seen from below it reads as printed. Its frame (the columns of axes()): x =
// the printed marker's x axis at heading `yaw` (world, radians from +x towards +y), normal =
// world -z (out of the printed face, towards the floor), y = normal x x. Corners follow ArUco's
// order (top-left, top-right, bottom-right, bottom-left as printed).
//
// map.json:
//   {"format": "ips-ceiling-map", "version": 1, "dictionary": "DICT_4X4_100",
//    "markers": [{"id": 3, "x": 1.20, "y": 0.85, "z": 2.80, "yaw": 0.0, "length": 0.30}, ...]}
// metres and radians, world frame. Each marker may carry "sigma": [sx, sy, sz, syaw] (its
// 1-sigma uncertainty from mapping; absent = exact).
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ips {

struct CeilingMarker {
  int id = -1;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< world, metres
  double yaw = 0.0;                                  ///< heading of the printed x axis seen from below, radians
  double length = 0.2;                               ///< black-square edge, metres
  std::optional<Eigen::Vector4d> sigma;              ///< 1-sigma of x, y, z (m) and yaw (rad), when mapped

  /// Columns: the marker's x, y and face normal (world -z) in the world.
  Eigen::Matrix3d axes() const;
  /// The black square's corners in the world, ArUco order.
  std::array<Eigen::Vector3d, 4> corners() const;
};

struct CeilingMap {
  std::string dictionary = "DICT_4X4_100";
  std::vector<CeilingMarker> markers;

  /// The marker with this id, or nullptr.
  const CeilingMarker* find(int id) const;

  /// Reads and checks a map.json. Throws ips::InputError naming the file and the entry
  /// ("map.json: markers[3].length: must be > 0") for a missing file, bad JSON, an unknown
  /// format or version, a duplicate id, a non-finite or out-of-range number.
  static CeilingMap load(const std::filesystem::path& path);
  /// The same from text; `name` is used in messages.
  static CeilingMap parse(const std::string& text, const std::string& name);
  /// JSON text of the map (load(save()) gives the map back).
  std::string to_json() const;
};

}  // namespace ips
