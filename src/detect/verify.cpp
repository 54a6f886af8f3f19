#include "verify.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace ips::detail {
namespace {

// Mean grey level over a 3x3 grid of points spanning the central half of a cell whose centre
// is at marker coordinates (u, v) in cell units.
double cell_mean(const cv::Mat& gray, const cv::Matx33d& H, double u, double v) {
  double sum = 0.0;
  int n = 0;
  for (int j = -1; j <= 1; ++j) {
    for (int i = -1; i <= 1; ++i) {
      const cv::Vec3d p = H * cv::Vec3d(u + 0.25 * i, v + 0.25 * j, 1.0);
      const double x = p[0] / p[2], y = p[1] / p[2];
      const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
      if (x0 < 0 || y0 < 0 || x0 + 1 >= gray.cols || y0 + 1 >= gray.rows) continue;
      const double fx = x - x0, fy = y - y0;
      const auto* r0 = gray.ptr<std::uint8_t>(y0);
      const auto* r1 = gray.ptr<std::uint8_t>(y0 + 1);
      sum += (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
             fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
      ++n;
    }
  }
  return n > 0 ? sum / n : -1.0;
}

}  // namespace

int count_ambiguous_cells(const cv::Mat& gray, const std::array<Point2, 4>& corners, int cells,
                          double ambiguity, double min_contrast) {
  // Marker coordinates: (0,0) top-left corner ... (cells, cells) bottom-right, in cells.
  const std::vector<cv::Point2f> src{{0.f, 0.f},
                                     {static_cast<float>(cells), 0.f},
                                     {static_cast<float>(cells), static_cast<float>(cells)},
                                     {0.f, static_cast<float>(cells)}};
  std::vector<cv::Point2f> dst;
  for (const auto& c : corners) dst.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
  const cv::Matx33d H = cv::getPerspectiveTransform(src, dst);

  std::vector<double> border, quiet;
  std::vector<double> values;
  for (int r = 0; r < cells; ++r) {
    for (int c = 0; c < cells; ++c) {
      const double m = cell_mean(gray, H, c + 0.5, r + 0.5);
      values.push_back(m);
      if (r == 0 || c == 0 || r == cells - 1 || c == cells - 1) border.push_back(m);
    }
  }
  // The quiet zone: a ring of points a third of a cell outside the border.
  for (int k = 0; k < cells; ++k) {
    const double t = k + 0.5;
    for (const auto& [u, v] : {std::pair{t, -0.35}, std::pair{t, cells + 0.35}, std::pair{-0.35, t},
                               std::pair{cells + 0.35, t}}) {
      const double m = cell_mean(gray, H, u, v);
      if (m >= 0) quiet.push_back(m);
    }
  }
  if (border.empty() || quiet.size() < 4) return cells * cells;
  std::nth_element(border.begin(), border.begin() + static_cast<long>(border.size() / 2),
                   border.end());
  std::nth_element(quiet.begin(), quiet.begin() + static_cast<long>(quiet.size() / 2), quiet.end());
  const double lo = border[border.size() / 2];
  const double hi = quiet[quiet.size() / 2];
  if (hi - lo < min_contrast) return cells * cells;
  const double mid = (lo + hi) / 2;
  int ambiguous = 0;
  for (double v : values) {
    if (v < 0 || std::abs(v - mid) < ambiguity * (hi - lo)) ++ambiguous;
  }
  return ambiguous;
}

}  // namespace ips::detail
