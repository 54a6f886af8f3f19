#include "cell_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace ips::detail {
namespace {

// Mean grey level over a 3x3 grid of points spanning the central half of a cell whose centre
// is at marker coordinates (u, v) in cell units; -1 if no point is inside the image.
double cell_mean(const cv::Mat& gray, const cv::Matx33d& H, double u, double v) {
  double sum = 0.0;
  int n = 0;
  for (int j = -1; j <= 1; ++j) {
    for (int i = -1; i <= 1; ++i) {
      const cv::Vec3d p = H * cv::Vec3d(u + 0.25 * i, v + 0.25 * j, 1.0);
      const double x = p[0] / p[2], y = p[1] / p[2];
      if (!(x >= 0 && y >= 0 && x < gray.cols - 1 && y < gray.rows - 1)) continue;
      const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
      const double fx = x - x0, fy = y - y0;
      const auto* r0 = gray.ptr<std::uint8_t>(y0);
      const auto* r1 = gray.ptr<std::uint8_t>(y0 + 1);
      sum += (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
      ++n;
    }
  }
  return n > 0 ? sum / n : -1.0;
}

double median(std::vector<double>& v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

CellReading read_cells(const cv::Mat& gray, const std::array<Point2, 4>& corners, int cells) {
  // Marker coordinates: (0,0) corner 0 ... (cells, cells) corner 2, in cells.
  const float n = static_cast<float>(cells);
  const std::vector<cv::Point2f> src{{0.f, 0.f}, {n, 0.f}, {n, n}, {0.f, n}};
  std::vector<cv::Point2f> dst;
  for (const auto& c : corners) dst.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
  const cv::Matx33d H = cv::getPerspectiveTransform(src, dst);

  CellReading r;
  r.values.reserve(static_cast<std::size_t>(cells * cells));
  std::vector<double> border, quiet;
  for (int row = 0; row < cells; ++row) {
    for (int c = 0; c < cells; ++c) {
      const double m = cell_mean(gray, H, c + 0.5, row + 0.5);
      r.values.push_back(m);
      if ((row == 0 || c == 0 || row == cells - 1 || c == cells - 1) && m >= 0) border.push_back(m);
    }
  }
  for (int k = 0; k < cells; ++k) {
    const double t = k + 0.5;
    for (const auto& [u, v] :
         {std::pair{t, -0.35}, std::pair{t, cells + 0.35}, std::pair{-0.35, t}, std::pair{cells + 0.35, t}}) {
      const double m = cell_mean(gray, H, u, v);
      if (m >= 0) quiet.push_back(m);
    }
  }
  if (border.empty() || quiet.size() < 4) return r;
  r.black = median(border);
  r.white = median(quiet);
  r.ok = true;
  return r;
}

}  // namespace ips::detail
