#include "ips/calib/live.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/calib/calibrate.h"

namespace ips::calib {

const char* tilt_name(Tilt t) {
  switch (t) {
    case Tilt::kFlat: return "facing the camera";
    case Tilt::kLeftNear: return "left edge towards the camera";
    case Tilt::kRightNear: return "right edge towards the camera";
    case Tilt::kTopNear: return "top edge towards the camera";
    case Tilt::kBottomNear: return "bottom edge towards the camera";
  }
  return "?";
}

ViewSelector::ViewSelector(const Board& board, cv::Size image, LiveOptions options)
    : board_(board), image_(image), grid_(coverage_grid(image)), options_(options) {
  grid_counts_.assign(static_cast<std::size_t>(grid_.area()), 0);
}

double ViewSelector::sharpness(const cv::Mat& gray, const BoardObservation& obs) {
  if (obs.px.empty()) return 0.0;
  std::vector<cv::Point2f> pts;
  for (const auto& p : obs.px) pts.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  const cv::Rect box = cv::boundingRect(pts) & cv::Rect(0, 0, gray.cols, gray.rows);
  if (box.area() < 16) return 0.0;
  cv::Mat lap;
  cv::Laplacian(gray(box), lap, CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(lap, mean, sd);
  double lo = 0, hi = 0;
  cv::minMaxLoc(gray(box), &lo, &hi);
  const double contrast = std::max(10.0, hi - lo);
  return sd[0] * sd[0] / (contrast * contrast);
}

Tilt ViewSelector::tilt_of(const BoardObservation& obs) const {
  if (obs.px.size() < 4) return Tilt::kFlat;
  std::vector<cv::Point2f> src, dst;
  for (std::size_t i = 0; i < obs.ids.size(); ++i) {
    const auto& c = board_.corners()[static_cast<std::size_t>(obs.ids[i])];
    src.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
    dst.emplace_back(static_cast<float>(obs.px[i].x), static_cast<float>(obs.px[i].y));
  }
  const cv::Mat H = cv::findHomography(src, dst);
  if (H.empty()) return Tilt::kFlat;
  // The projective row: how the depth changes across the board, relative to its centre
  // (w > 1 at a side means that side is farther). Lens distortion bends this a little; the
  // sign and rough size are all that is needed here.
  const double cx = 0.5 * board_.spec().width(), cy = 0.5 * board_.spec().height();
  const double w0 = H.at<double>(2, 0) * cx + H.at<double>(2, 1) * cy + H.at<double>(2, 2);
  const double tx = H.at<double>(2, 0) * board_.spec().width() / w0;
  const double ty = H.at<double>(2, 1) * board_.spec().height() / w0;
  constexpr double kFlat = 0.12;  // about 15 degrees for a board at arm's length
  if (std::hypot(tx, ty) < kFlat) return Tilt::kFlat;
  if (std::abs(tx) >= std::abs(ty)) return tx > 0 ? Tilt::kLeftNear : Tilt::kRightNear;
  return ty > 0 ? Tilt::kTopNear : Tilt::kBottomNear;  // board y runs down the print
}

ViewSelector::Decision ViewSelector::offer(const cv::Mat& gray, const BoardObservation& obs) {
  Decision d;
  const BoardObservation prev = previous_;
  previous_ = obs;
  const int need = std::max(8, static_cast<int>(options_.min_corner_fraction * board_.spec().corner_count()));
  if (static_cast<int>(obs.ids.size()) < need) {
    d.reason = obs.ids.empty() ? "no board" : "too little of the board visible";
    return d;
  }
  // Still: the same corners in the previous frame, barely moved.
  std::map<int, cv::Point2d> before;
  for (std::size_t i = 0; i < prev.ids.size(); ++i) before[prev.ids[i]] = prev.px[i];
  double motion = 0.0;
  int common = 0;
  for (std::size_t i = 0; i < obs.ids.size(); ++i) {
    if (auto it = before.find(obs.ids[i]); it != before.end()) {
      motion += cv::norm(obs.px[i] - it->second);
      ++common;
    }
  }
  if (common < need / 2 || motion / std::max(1, common) > options_.still_px) {
    d.reason = "hold the board still";
    return d;
  }
  const double sharp = sharpness(gray, obs);
  best_sharpness_ = std::max(best_sharpness_, sharp);
  if (sharp < options_.sharp_fraction * best_sharpness_) {
    d.reason = "blurred";
    return d;
  }
  // Adds coverage or a tilt that is still wanted?
  int new_cells = 0;
  std::vector<int> cells;
  for (const auto& p : obs.px) {
    const int gx = std::clamp(static_cast<int>(p.x * grid_.width / image_.width), 0, grid_.width - 1);
    const int gy = std::clamp(static_cast<int>(p.y * grid_.height / image_.height), 0, grid_.height - 1);
    const int c = gy * grid_.width + gx;
    cells.push_back(c);
    if (grid_counts_[static_cast<std::size_t>(c)] == 0 &&
        std::find(cells.begin(), cells.end() - 1, c) == cells.end() - 1)
      ++new_cells;
  }
  const Tilt tilt = tilt_of(obs);
  const bool tilt_wanted = tilt_counts_[static_cast<int>(tilt)] < options_.views_per_tilt;
  if (new_cells == 0 && !tilt_wanted) {
    d.reason = "adds nothing: move the board to an empty part of the image or tilt it";
    return d;
  }
  for (int c : cells) ++grid_counts_[static_cast<std::size_t>(c)];
  ++tilt_counts_[static_cast<int>(tilt)];
  kept_.push_back(obs);
  d.kept = true;
  char buf[160];
  std::snprintf(buf, sizeof buf, "kept: %d new grid cell(s), board %s", new_cells, tilt_name(tilt));
  d.reason = buf;
  return d;
}

std::vector<std::string> ViewSelector::missing() const {
  std::vector<std::string> out;
  auto covered = [&](int gx, int gy) { return grid_counts_[static_cast<std::size_t>(gy * grid_.width + gx)] > 0; };
  int edge = 0, edge_covered = 0;
  for (int gy = 0; gy < grid_.height; ++gy) {
    for (int gx = 0; gx < grid_.width; ++gx) {
      if (gx == 0 || gy == 0 || gx == grid_.width - 1 || gy == grid_.height - 1) {
        ++edge;
        edge_covered += covered(gx, gy) ? 1 : 0;
      }
    }
  }
  const int corners_covered = covered(0, 0) + covered(grid_.width - 1, 0) + covered(0, grid_.height - 1) +
                              covered(grid_.width - 1, grid_.height - 1);
  if (edge_covered < edge / 2) out.push_back("edges of the image");
  if (corners_covered < 4) out.push_back("corners of the image");
  int inner = 0, inner_covered = 0;
  for (int gy = 1; gy + 1 < grid_.height; ++gy)
    for (int gx = 1; gx + 1 < grid_.width; ++gx) {
      ++inner;
      inner_covered += covered(gx, gy) ? 1 : 0;
    }
  if (inner_covered < 0.8 * inner) out.push_back("middle of the image");
  for (int t = 1; t < 5; ++t) {
    if (tilt_counts_[t] < options_.views_per_tilt)
      out.push_back(std::string("tilt the board: ") + tilt_name(static_cast<Tilt>(t)));
  }
  return out;
}

std::string ViewSelector::progress() const {
  std::string s;
  char buf[128];
  int cov = 0;
  for (int c : grid_counts_) cov += c > 0 ? 1 : 0;
  std::snprintf(buf, sizeof buf, "views kept %zu/%d, coverage %.0f%% of the %dx%d grid:\n", kept_.size(),
                options_.target_views, 100.0 * cov / grid_.area(), grid_.width, grid_.height);
  s += buf;
  for (int gy = 0; gy < grid_.height; ++gy) {
    s += "  |";
    for (int gx = 0; gx < grid_.width; ++gx)
      s += grid_counts_[static_cast<std::size_t>(gy * grid_.width + gx)] > 0 ? '#' : '.';
    s += "|\n";
  }
  const auto m = missing();
  s += m.empty() ? "missing: nothing\n" : "missing:";
  for (std::size_t i = 0; i < m.size(); ++i) s += (i ? ", " : " ") + m[i] + (i + 1 == m.size() ? "\n" : "");
  return s;
}

}  // namespace ips::calib
