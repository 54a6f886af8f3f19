#include "edge_refine.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace ips::detail {
namespace {

double sample(const cv::Mat& g, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const std::uint8_t* r0 = g.ptr<std::uint8_t>(y0);
  const std::uint8_t* r1 = g.ptr<std::uint8_t>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

// An edge in its own frame: origin o, unit direction t, unit normal n; the edge is
// q(s) = c0 + c1 s + c2 s^2 along n at arc parameter s along t.
struct Edge {
  Point2 o, t, n;
  double c[3] = {0, 0, 0};
  Point2 at(double s) const {
    const double q = c[0] + s * (c[1] + s * c[2]);
    return {o.x + s * t.x + q * n.x, o.y + s * t.y + q * n.y};
  }
  Point2 slope(double s) const {  // d/ds of at(s)
    const double dq = c[1] + 2 * s * c[2];
    return {t.x + dq * n.x, t.y + dq * n.y};
  }
  double param(Point2 p) const { return (p.x - o.x) * t.x + (p.y - o.y) * t.y; }
  double offset(Point2 p) const { return (p.x - o.x) * n.x + (p.y - o.y) * n.y; }
};

// Least squares q = c0 + c1 s (+ c2 s^2) over the points; false if degenerate.
bool fit_edge(const std::vector<Point2>& pts, bool quadratic, Edge& e) {
  const int k = quadratic ? 3 : 2;
  if (static_cast<int>(pts.size()) < k + 2) return false;
  cv::Matx33d A = cv::Matx33d::zeros();
  cv::Vec3d b(0, 0, 0);
  for (const auto& p : pts) {
    const double s = e.param(p), q = e.offset(p);
    const double v[3] = {1, s, s * s};
    for (int r = 0; r < k; ++r) {
      b[r] += v[r] * q;
      for (int c = 0; c < k; ++c) A(r, c) += v[r] * v[c];
    }
  }
  if (!quadratic) A(2, 2) = 1;
  cv::Vec3d x;
  if (!cv::solve(A, b, x, cv::DECOMP_CHOLESKY)) return false;
  e.c[0] = x[0];
  e.c[1] = x[1];
  e.c[2] = quadratic ? x[2] : 0.0;
  return std::isfinite(e.c[0] + e.c[1] + e.c[2]);
}

// Where edge `in` (ending at the corner) meets edge `out` (starting there): intersect their
// tangent lines at the current estimate, a few times (exact for lines after one step).
bool meet(const Edge& in, const Edge& out, Point2& p) {
  for (int it = 0; it < 4; ++it) {
    const Point2 a = in.at(in.param(p)), da = in.slope(in.param(p));
    const Point2 b = out.at(out.param(p)), db = out.slope(out.param(p));
    const double det = da.x * (-db.y) - da.y * (-db.x);
    if (std::abs(det) < 1e-12) return false;
    const double rx = b.x - a.x, ry = b.y - a.y;
    const double u = (rx * (-db.y) - ry * (-db.x)) / det;
    p = {a.x + u * da.x, a.y + u * da.y};
  }
  return std::isfinite(p.x) && std::isfinite(p.y);
}

}  // namespace

bool offset_edges(std::array<Point2, 4>& q, double d) {
  Point2 c{0, 0};
  for (const auto& p : q) {
    c.x += p.x / 4;
    c.y += p.y / 4;
  }
  // Edge i from q[i] to q[i+1], as a point on the moved line and a direction.
  std::array<Point2, 4> at{}, dir{};
  for (std::size_t i = 0; i < 4; ++i) {
    const Point2 a = q[i], b = q[(i + 1) % 4];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (!(len > 0)) return false;
    dir[i] = {(b.x - a.x) / len, (b.y - a.y) / len};
    Point2 n{dir[i].y, -dir[i].x};
    if (n.x * ((a.x + b.x) / 2 - c.x) + n.y * ((a.y + b.y) / 2 - c.y) < 0) n = {-n.x, -n.y};
    at[i] = {a.x + d * n.x, a.y + d * n.y};
  }
  std::array<Point2, 4> out{};
  for (std::size_t i = 0; i < 4; ++i) {
    // Corner i: edge i-1 meets edge i.
    const std::size_t j = (i + 3) % 4;
    const double det = dir[j].x * -dir[i].y + dir[i].x * dir[j].y;
    if (std::abs(det) < 1e-6) return false;
    const double rx = at[i].x - at[j].x, ry = at[i].y - at[j].y;
    const double u = (rx * -dir[i].y + dir[i].x * ry) / det;
    out[i] = {at[j].x + u * dir[j].x, at[j].y + u * dir[j].y};
  }
  q = out;
  return true;
}

bool refine_corners_by_edges(const cv::Mat& gray, std::array<Point2, 4>& corners, int cells, const CameraModel* camera,
                             const EdgeRefineOptions& o) {
  Point2 centre{0, 0};
  for (const auto& c : corners) {
    centre.x += c.x / 4;
    centre.y += c.y / 4;
  }
  std::array<Edge, 4> edges{};
  std::vector<Point2> pts;
  // Corners in the fitting space: undistorted (where a flat marker's edges are straight
  // lines) with a camera model, else pixels (where they curve: fit parabolas).
  const bool quadratic = camera == nullptr;
  std::array<Point2, 4> fc = corners;
  if (camera != nullptr) {
    for (auto& c : fc) {
      c = camera->undistort(c);
      if (std::isnan(c.x)) return false;
    }
  }
  for (std::size_t e = 0; e < 4; ++e) {
    const Point2 a = corners[e];
    const Point2 b = corners[(e + 1) % 4];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (len < 8) return false;
    const double tx = (b.x - a.x) / len, ty = (b.y - a.y) / len;
    double nx = ty, ny = -tx;  // outward normal: away from the marker centre
    const double mx = (a.x + b.x) / 2 - centre.x, my = (a.y + b.y) / 2 - centre.y;
    if (nx * mx + ny * my < 0) {
      nx = -nx;
      ny = -ny;
    }
    // Stay inside the black border cell on one side and the white margin on the other.
    const double half = std::min(o.max_profile_half_px, 0.45 * len / cells);
    const double step = 0.25;
    const int n_prof = static_cast<int>(std::floor(half / step));
    pts.clear();
    const int n_samples = std::max(3, static_cast<int>(len * (1 - 2 * o.end_margin) / o.sample_step_px));
    for (int k = 0; k <= n_samples; ++k) {
      const double s = o.end_margin + (1 - 2 * o.end_margin) * k / n_samples;
      const double px = a.x + s * (b.x - a.x), py = a.y + s * (b.y - a.y);
      const double x_lo = px - (half + 1) * std::abs(nx), x_hi = px + (half + 1) * std::abs(nx);
      const double y_lo = py - (half + 1) * std::abs(ny), y_hi = py + (half + 1) * std::abs(ny);
      if (x_lo < 1 || y_lo < 1 || x_hi > gray.cols - 2 || y_hi > gray.rows - 2) continue;
      // Profile from inside (black) to outside (white).
      double prof[64];
      const int m = 2 * n_prof + 1;
      for (int i = 0; i < m; ++i) {
        const double d = (i - n_prof) * step;
        prof[i] = sample(gray, px + d * nx, py + d * ny);
      }
      const double lo = (prof[0] + prof[1]) / 2;
      const double hi = (prof[m - 1] + prof[m - 2]) / 2;
      if (hi - lo < 20) continue;  // no clear dark-to-bright edge here (occlusion, glare)
      const double mid = (lo + hi) / 2;
      // The mid-level crossing nearest the profile centre.
      double best = 1e9;
      for (int i = 0; i + 1 < m; ++i) {
        if ((prof[i] - mid) * (prof[i + 1] - mid) <= 0 && prof[i + 1] != prof[i]) {
          const double d = (i + (mid - prof[i]) / (prof[i + 1] - prof[i]) - n_prof) * step;
          if (std::abs(d) < std::abs(best)) best = d;
        }
      }
      if (std::abs(best) > half) continue;
      Point2 p{px + best * nx, py + best * ny};
      if (camera != nullptr) {
        p = camera->undistort(p);
        if (std::isnan(p.x)) continue;
      }
      pts.push_back(p);
    }
    Edge& edge = edges[e];
    {
      const Point2 fa = fc[e], fb = fc[(e + 1) % 4];
      const double fl = std::hypot(fb.x - fa.x, fb.y - fa.y);
      edge.o = fa;
      edge.t = {(fb.x - fa.x) / fl, (fb.y - fa.y) / fl};
      edge.n = {-edge.t.y, edge.t.x};
    }
    if (!fit_edge(pts, quadratic, edge)) return false;
    // One pass of outlier rejection (a JPEG block edge or a stray highlight).
    std::vector<double> res;
    for (const auto& p : pts) {
      const double sp = edge.param(p);
      res.push_back(std::abs(edge.offset(p) - (edge.c[0] + sp * (edge.c[1] + sp * edge.c[2]))));
    }
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double cut = 3.0 * sorted[sorted.size() / 2] + 1e-12;
    std::vector<Point2> kept;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (res[i] <= cut) kept.push_back(pts[i]);
    }
    if (kept.size() >= 5 && kept.size() < pts.size()) fit_edge(kept, quadratic, edge);
  }
  std::array<Point2, 4> out{};
  for (std::size_t i = 0; i < 4; ++i) {
    // Corner i joins edge i-1 (from corner i-1 to i) and edge i (from i to i+1).
    Point2 p = fc[i];
    if (!meet(edges[(i + 3) % 4], edges[i], p)) return false;
    if (camera != nullptr) p = camera->project(p);
    if (!std::isfinite(p.x) || std::hypot(p.x - corners[i].x, p.y - corners[i].y) > o.max_shift_px) return false;
    out[i] = p;
  }
  corners = out;
  return true;
}

}  // namespace ips::detail
