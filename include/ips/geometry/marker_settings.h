// The markers section of the lab's configuration: the dictionary, the printed sizes, known
// heights and per-marker settings. Parsed by src/geometry/parse_markers.cpp.
#pragma once

#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>

#include "ips/geometry/marker_geometry.h"

namespace ips {

/// Per-marker settings (markers.ids.<id>).
struct MarkerInfo {
  std::string name;                   ///< optional, shown by `ips listen`
  double edge_length = std::nan("");  ///< metres; NaN = markers.edge_length
  double height = std::nan("");       ///< known world z, metres; NaN = markers.height
  /// A marker that stays put (a reference left on the floor): its surveyed world position,
  /// metres. ipsd checks every camera's view of it (docs/survey.md, a bumped camera).
  std::optional<std::array<double, 3>> fixed;
  bool publish = true;  ///< false: never sent to any output; default false for fixed markers
};

struct MarkerConfig {
  std::string dictionary = "DICT_4X4_100";  ///< OpenCV predefined dictionary name
  double edge_length = 0.20;                ///< default printed edge length, metres
  double height = std::nan("");             ///< default known height, metres; NaN = unknown
  std::map<int, MarkerInfo> ids;

  MarkerSizes sizes() const;
  /// Known world z of marker `id` (per-ID, else the default), NaN if unknown.
  double height_of(int id) const;
  /// False for markers configured with publish: false (fixed markers by default).
  bool published(int id) const;
};

}  // namespace ips
