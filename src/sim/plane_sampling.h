// Shared by the floor renderer and the board renderer: the plane coordinates seen at a
// sub-pixel position, bilinearly interpolated from the plane coordinates of the pixel centres.
#pragma once

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace ips::sim {

/// Plane coordinates (a, b) at image position (fx, fy) of `ab` (CV_32FC2, one entry per pixel
/// centre, not empty), clamped to the grid: supersampling an edge pixel stays inside. A grid of
/// one row or column (a marker box cut to one pixel by the image border) is constant along it.
inline cv::Vec2d plane_coords_at(const cv::Mat& ab, double fx, double fy) {
  const int iy = std::clamp(static_cast<int>(std::floor(fy)), 0, std::max(0, ab.rows - 2));
  const int ix = std::clamp(static_cast<int>(std::floor(fx)), 0, std::max(0, ab.cols - 2));
  const int iy1 = std::min(iy + 1, ab.rows - 1), ix1 = std::min(ix + 1, ab.cols - 1);
  const double ty = fy - iy, tx = fx - ix;
  const auto* r0 = ab.ptr<cv::Vec2f>(iy);
  const auto* r1 = ab.ptr<cv::Vec2f>(iy1);
  cv::Vec2d out;
  for (int k = 0; k < 2; ++k)
    out[k] = (1 - ty) * ((1 - tx) * r0[ix][k] + tx * r0[ix1][k]) + ty * ((1 - tx) * r1[ix][k] + tx * r1[ix1][k]);
  return out;
}

}  // namespace ips::sim
