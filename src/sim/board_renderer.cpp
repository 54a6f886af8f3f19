// The calibration board drawn through a scene camera: per pixel, the viewing ray from the
// camera renderer's ray map meets the board plane; the printed colour there (exact, from the
// board geometry) times the camera's gain gives the grey level. Pixels on a colour boundary
// are supersampled like the marker renderer's (sub-pixel rays by bilinear interpolation of
// the pixel-centre rays).
#include "ips/sim/board_renderer.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "plane_sampling.h"

namespace ips::sim {
namespace {

constexpr float kNoHitF = std::numeric_limits<float>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

}  // namespace

BoardRenderer::BoardRenderer(const CameraRenderer& camera, const calib::Board& board, double paper_margin)
    : camera_(camera), board_(board), margin_(paper_margin) {}

BoardTruth BoardRenderer::truth(const BoardPose& pose) const {
  const CameraModel& model = camera_.camera().model;
  const int w = model.size().width, h = model.size().height;
  BoardTruth t;
  for (const auto& c : board_.corners()) {
    const Eigen::Vector3d p = pose.R * Eigen::Vector3d(c.x, c.y, c.z) + pose.t;
    const bool in_front = p.z() > 1e-6 && std::atan2(std::hypot(p.x(), p.y()), p.z()) < model.max_theta() - 1e-6;
    const Point2 px = in_front ? model.project({p.x() / p.z(), p.y() / p.z()}) : Point2{-1e9, -1e9};
    const bool vis = in_front && px.x >= 4 && px.y >= 4 && px.x <= w - 5 && px.y <= h - 5;
    t.corners_px.push_back(px);
    t.visible.push_back(vis);
    t.visible_count += vis ? 1 : 0;
  }
  return t;
}

void BoardRenderer::render(const BoardPose& pose, const BoardLook& look, cv::Mat& gray,
                           std::uint64_t noise_index) const {
  const CameraModel& model = camera_.camera().model;
  const int W = model.size().width, H = model.size().height;
  camera_.background().copyTo(gray);
  const calib::BoardSpec& spec = board_.spec();
  const double x_lo = -margin_, y_lo = -margin_;
  const double x_hi = spec.width() + margin_, y_hi = spec.height() + margin_;

  // Bounding box of the sheet's outline (densely sampled: fisheye edges curve).
  double bx0 = 1e18, by0 = 1e18, bx1 = -1e18, by1 = -1e18;
  constexpr int kPerEdge = 32;
  for (int e = 0; e < 4; ++e) {
    for (int k = 0; k <= kPerEdge; ++k) {
      const double s = static_cast<double>(k) / kPerEdge;
      const double a = e == 0 ? x_lo + s * (x_hi - x_lo) : (e == 1 ? x_hi : (e == 2 ? x_hi - s * (x_hi - x_lo) : x_lo));
      const double b = e == 0 ? y_lo : (e == 1 ? y_lo + s * (y_hi - y_lo) : (e == 2 ? y_hi : y_hi - s * (y_hi - y_lo)));
      const Eigen::Vector3d p = pose.R * Eigen::Vector3d(a, b, 0) + pose.t;
      if (!(p.z() > 1e-6) || std::atan2(std::hypot(p.x(), p.y()), p.z()) >= model.max_theta()) {
        // Part of the sheet is outside the lens' field: it may cover any pixel near the rim.
        bx0 = by0 = 0;
        bx1 = W - 1;
        by1 = H - 1;
        continue;
      }
      const Point2 px = model.project({p.x() / p.z(), p.y() / p.z()});
      bx0 = std::min(bx0, px.x);
      by0 = std::min(by0, px.y);
      bx1 = std::max(bx1, px.x);
      by1 = std::max(by1, px.y);
    }
  }
  // Points just in front of the camera project far outside the image: clamp before casting.
  auto lim = [&](double v) { return std::clamp(v, -1e6, 1e6); };
  bx0 = lim(bx0), by0 = lim(by0), bx1 = lim(bx1), by1 = lim(by1);
  const int pad = 3 + static_cast<int>(std::ceil(3 * look.blur_sigma));
  const int x0 = std::max(0, static_cast<int>(std::floor(bx0)) - pad);
  const int y0 = std::max(0, static_cast<int>(std::floor(by0)) - pad);
  const int x1 = std::min(W - 1, static_cast<int>(std::ceil(bx1)) + pad);
  const int y1 = std::min(H - 1, static_cast<int>(std::ceil(by1)) + pad);
  if (x0 > x1 || y0 > y1) {
    camera_.add_noise(gray, noise_index);
    return;
  }
  const int bw = x1 - x0 + 1, bh = y1 - y0 + 1;

  // Board-plane coordinates of every pixel centre in the box (NaN: the ray misses the plane).
  const Eigen::Matrix3d Rt = pose.R.transpose();
  const Eigen::Vector3d o = -(Rt * pose.t);  // camera centre in the board frame
  cv::Mat ab(bh, bw, CV_32FC2);
  for (int y = 0; y < bh; ++y) {
    const auto* uv = camera_.rays().ptr<cv::Vec2f>(y0 + y) + x0;
    auto* out = ab.ptr<cv::Vec2f>(y);
    for (int x = 0; x < bw; ++x) {
      const Eigen::Vector3d d = Rt * Eigen::Vector3d(uv[x][0], uv[x][1], 1.0);
      const double s = -o.z() / d.z();
      if (!(s > 0)) {
        out[x] = {kNoHitF, kNoHitF};
        continue;
      }
      // Rays almost parallel to the board meet it very far away: clamp to stay in float range.
      out[x] = {static_cast<float>(std::clamp(o.x() + s * d.x(), -1e6, 1e6)),
                static_cast<float>(std::clamp(o.y() + s * d.y(), -1e6, 1e6))};
    }
  }
  // Region and colour of a board point: -1 = off the sheet (the floor shows).
  auto sample = [&](double a, double b, int& region) -> int {
    if (!(a >= x_lo && a <= x_hi && b >= y_lo && b <= y_hi)) {  // also NaN
      region = -1;
      return -1;
    }
    const int c = board_.colour_at(a, b, &region);
    if (c < 0) {
      region = -2;  // paper margin
      return 1;
    }
    return c;
  };
  cv::Mat region(bh, bw, CV_32S), colour(bh, bw, CV_8S);
  for (int y = 0; y < bh; ++y) {
    const auto* r = ab.ptr<cv::Vec2f>(y);
    auto* g = region.ptr<int>(y);
    auto* c = colour.ptr<std::int8_t>(y);
    for (int x = 0; x < bw; ++x) c[x] = static_cast<std::int8_t>(sample(r[x][0], r[x][1], g[x]));
  }
  const auto& rs = camera_.scene().render;
  const double white = rs.white, black = rs.black;
  const double gc = std::cos(look.gradient_dir), gs = std::sin(look.gradient_dir);
  const double half_extent = 0.5 * (std::abs(gc) * (x_hi - x_lo) + std::abs(gs) * (y_hi - y_lo));
  const double cx = 0.5 * (x_lo + x_hi), cy = 0.5 * (y_lo + y_hi);
  auto light = [&](double a, double b) {
    return 1.0 + 0.5 * look.gradient * ((a - cx) * gc + (b - cy) * gs) / half_extent;
  };
  const int S = std::max(1, rs.supersample);
  cv::Mat out(bh, bw, CV_32F);
  for (int y = 0; y < bh; ++y) {
    const auto* bg = camera_.background().ptr<std::uint8_t>(y0 + y) + x0;
    const float* gain = camera_.gain().ptr<float>(y0 + y) + x0;
    const auto* reg = region.ptr<int>(y);
    const auto* col = colour.ptr<std::int8_t>(y);
    const auto* r = ab.ptr<cv::Vec2f>(y);
    float* o_row = out.ptr<float>(y);
    auto value = [&](int c, double a, double b, int x) -> double {
      if (c < 0) return bg[x];
      return (c == 0 ? black : white) * gain[x] * light(a, b);
    };
    for (int x = 0; x < bw; ++x) {
      // A pixel whose diagonal neighbours' centres share its region lies wholly inside it
      // (regions are convex, the mapping is smooth).
      if (y > 0 && y + 1 < bh && x > 0 && x + 1 < bw) {
        const int here = reg[x];
        const int* up = region.ptr<int>(y - 1);
        const int* dn = region.ptr<int>(y + 1);
        if (up[x - 1] == here && up[x + 1] == here && dn[x - 1] == here && dn[x + 1] == here) {
          o_row[x] = static_cast<float>(value(col[x], r[x][0], r[x][1], x));
          continue;
        }
      }
      double sum = 0.0;
      for (int sy = 0; sy < S; ++sy) {
        const double fy = y + (sy + 0.5) / S - 0.5;
        for (int sx = 0; sx < S; ++sx) {
          const cv::Vec2d ab_at = plane_coords_at(ab, x + (sx + 0.5) / S - 0.5, fy);
          const double a = ab_at[0], b = ab_at[1];
          int g = 0;
          sum += value(sample(a, b, g), a, b, x);
        }
      }
      o_row[x] = static_cast<float>(sum / (S * S));
    }
  }
  if (look.blur_sigma > 0.05) cv::GaussianBlur(out, out, cv::Size(0, 0), look.blur_sigma);
  // The box's outer `pad` ring is floor either way; writing it back keeps the blur seamless.
  out.convertTo(gray(cv::Rect(x0, y0, bw, bh)), CV_8U);
  camera_.add_noise(gray, noise_index);
}

std::vector<BoardView> generate_board_views(const BoardRenderer& renderer, const BoardViewOptions& opt) {
  const CameraModel& model = renderer.camera().camera().model;
  const calib::BoardSpec& spec = renderer.board().spec();
  const int W = model.size().width, H = model.size().height;
  std::mt19937_64 rng(opt.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // A grid of about `views` cells with the image's aspect ratio.
  const int gx = std::max(1, static_cast<int>(std::round(std::sqrt(opt.views * double(W) / H))));
  const int gy = std::max(1, (opt.views + gx - 1) / gx);
  std::vector<int> cells;
  for (int i = 0; i < gx * gy; ++i) {
    const double cx = (i % gx + 0.5) * W / gx, cy = (i / gx + 0.5) * H / gy;
    if (model.has_ray({cx, cy})) cells.push_back(i);
  }
  // The image's corner cells first, then its edges, then the inside (each group shuffled):
  // when there are more cells than views, the ones left out are inside, where neighbouring
  // views overlap anyway, and the edges, where a lens model is hardest to pin down, are covered.
  std::shuffle(cells.begin(), cells.end(), rng);
  auto rank = [&](int c) {
    const bool ex = c % gx == 0 || c % gx == gx - 1, ey = c / gx == 0 || c / gx == gy - 1;
    return ex && ey ? 0 : (ex || ey ? 1 : 2);
  };
  std::stable_sort(cells.begin(), cells.end(), [&](int a, int b) { return rank(a) < rank(b); });
  const double f = model.K()(0, 0);
  const Eigen::Vector3d half(0.5 * spec.width(), 0.5 * spec.height(), 0.0);
  std::vector<BoardView> out;
  for (int k = 0; k < opt.views; ++k) {
    const int cell = cells.empty() ? 0 : cells[static_cast<std::size_t>(k) % cells.size()];
    bool done = false;
    for (int attempt = 0; attempt < 400 && !done; ++attempt) {
      // Each failed attempt pulls the aim point a little towards the image centre.
      const double pull = std::min(0.9, attempt / 400.0);
      double px = (cell % gx + u(rng)) * W / gx, py = (cell / gx + u(rng)) * H / gy;
      px += pull * (0.5 * W - px);
      py += pull * (0.5 * H - py);
      const Point2 n = model.undistort({px, py});
      if (!std::isfinite(n.x)) continue;
      const Eigen::Vector3d ray = Eigen::Vector3d(n.x, n.y, 1.0).normalized();
      const double size = opt.size_min + u(rng) * (opt.size_max - opt.size_min);
      const double dist = f * spec.width() / (size * W);
      // Facing the camera: the board's z points into the sheet, i.e. away from the camera;
      // x as close to camera x as possible (the print appears upright).
      const Eigen::Vector3d z = ray;
      const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - z * z.x()).normalized();
      Eigen::Matrix3d R;
      R.col(0) = x;
      R.col(1) = z.cross(x);
      R.col(2) = z;
      const double roll = (u(rng) - 0.5) * kPi / 2;
      const double tilt = (opt.tilt_min_deg + u(rng) * (opt.tilt_max_deg - opt.tilt_min_deg)) * kPi / 180;
      const double axis = u(rng) * 2 * kPi;
      R = R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
          Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(axis), std::sin(axis), 0)).toRotationMatrix();
      BoardView v;
      v.pose.R = R;
      v.pose.t = dist * ray - R * half;
      // Not edge-on: the normal vs. the line of sight to the centre.
      if (R.col(2).dot(ray) < std::cos(70.0 * kPi / 180)) continue;
      v.truth = renderer.truth(v.pose);
      if (v.truth.visible_count < opt.min_visible * spec.corner_count()) continue;
      v.look.blur_sigma = u(rng) * opt.max_blur;
      v.look.gradient = u(rng) * opt.max_gradient;
      v.look.gradient_dir = u(rng) * 2 * kPi;
      out.push_back(std::move(v));
      done = true;
    }
  }
  return out;
}

}  // namespace ips::sim
