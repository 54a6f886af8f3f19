// Grey levels of a marker's cells read through the homography of its corners (internal to
// detect/): shared by full-resolution decoding and verification.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/core/observation.h"

namespace ips::detail {

struct CellReading {
  /// cells x cells mean grey levels, row-major from the marker's corner 0; -1 where the
  /// cell's centre lies outside the image.
  std::vector<double> values;
  double black = 0;  ///< median of the border cells
  double white = 0;  ///< median of the quiet zone (a third of a cell outside the border)
  bool ok = false;   ///< false when the quiet zone is (mostly) outside the image
  double mid() const { return (black + white) / 2; }
  double contrast() const { return white - black; }
};

/// Reads each cell as the mean over a 3x3 grid of points spanning its central half, so a
/// corner error up to a quarter of a cell does not mix neighbouring cells. `cells` counts
/// the border: bits + 2.
CellReading read_cells(const cv::Mat& gray, const std::array<Point2, 4>& corners, int cells);

}  // namespace ips::detail
