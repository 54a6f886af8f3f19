#include "candidates.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "edge_refine.h"

namespace ips::detail {
namespace {

Point2 centre(const Candidate& c) {
  Point2 p{0, 0};
  for (const auto& q : c.corners) {
    p.x += q.x / 4;
    p.y += q.y / 4;
  }
  return p;
}

// Undecoded squares up to this side at the search scale are read again at full resolution:
// below it the cells are too few pixels for OpenCV's decoding at that scale, and the
// rejected squares of a textured floor are mostly smaller and cheap to dismiss.
constexpr double kRereadBelowCoarsePx = 2.0 * kMinCoarseMarkerPx;

}  // namespace

double Candidate::side() const {
  double s = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    s += std::hypot(corners[(i + 1) % 4].x - corners[i].x, corners[(i + 1) % 4].y - corners[i].y);
  }
  return s / 4;
}

void CandidateSearch::configure(const DetectorOptions& o, cv::Ptr<cv::aruco::Dictionary> dictionary) {
  options_ = o;
  dictionary_ = std::move(dictionary);
  params_ = cv::aruco::DetectorParameters::create();
  params_->adaptiveThreshConstant = o.threshold_constant;
  params_->errorCorrectionRate = o.error_correction_rate;
  params_->maxErroneousBitsInBorderRate = o.max_border_error_rate;
  params_->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;  // refined at full resolution
}

void CandidateSearch::run(const cv::Mat& region, cv::Point offset, int scale, double min_side_px, double fine_below_px,
                          std::vector<Candidate>& out) {
  if (scale > 1) {
    cv::resize(region, small_, cv::Size(region.cols / scale, region.rows / scale), 0, 0, cv::INTER_AREA);
    pass(small_, offset, scale, std::max(min_side_px, 0.0), 0.0, out);
  } else {
    pass(region, offset, 1, min_side_px, 0.0, out);
  }
  if (fine_below_px > 0) pass(region, offset, 1, min_side_px, fine_below_px * 1.25, out);
}

void CandidateSearch::pass(const cv::Mat& image, cv::Point offset, int s, double min_side_px, double max_side_px,
                           std::vector<Candidate>& out) {
  const double side = std::max(image.cols, image.rows);
  if (image.cols < 8 || image.rows < 8) return;
  // OpenCV's limits are perimeters as fractions of the larger side of the searched image,
  // compared with the number of points of the 8-connected contour: a diagonal step is one
  // point, so a square turned 45 degrees has only 1/sqrt(2) of its perimeter in points
  // (24 px markers at 30-45 degrees near the fisheye edge were dropped here). The contour
  // also runs through the centres of the square's boundary pixels (~4 px short of the
  // perimeter) and a fisheye view or a tilt shortens some sides: 20 % slack on top.
  params_->minMarkerPerimeterRate = 0.8 / std::sqrt(2.0) * 4.0 * min_side_px / s / side;
  params_->maxMarkerPerimeterRate = max_side_px > 0
                                        ? std::min(options_.max_perimeter_rate, 4.0 * max_side_px / s / side)
                                        : options_.max_perimeter_rate;
  if (params_->maxMarkerPerimeterRate <= params_->minMarkerPerimeterRate) return;
  // A small square shrunk loses its corners to ~1 px of blur: at the default 3 % of the
  // perimeter the polygon approximation of a 12-15 px square keeps extra vertices and the
  // square is lost (a 30 px marker near the fisheye edge, seen at half scale).
  params_->polygonalApproxAccuracyRate = s > 1 ? 0.05 : 0.03;
  // OpenCV drops squares within minDistanceToBorder (3) pixels of the searched image's border:
  // at a coarse scale that is 3 x s full-resolution pixels, and a marker whose corner is 4-5 px
  // from the frame edge (found by OpenCV at full resolution) was lost. Keep the full-resolution
  // distance; inside an ROI the border is the ROI's, which has margin around every marker.
  params_->minDistanceToBorder = std::max(1, 3 / s);
  const std::vector<int>& windows = options_.threshold_windows;
  // Windows given as an arithmetic sequence are one OpenCV call (its own loop over them),
  // other lists one call each.
  bool arithmetic = windows.size() <= 2;
  for (std::size_t i = 2; i < windows.size(); ++i) {
    arithmetic = arithmetic && windows[i] - windows[i - 1] == windows[1] - windows[0];
  }
  const std::size_t calls = arithmetic ? 1 : windows.size();
  for (std::size_t call = 0; call < calls; ++call) {
    if (arithmetic) {
      params_->adaptiveThreshWinSizeMin = windows.front();
      params_->adaptiveThreshWinSizeMax = windows.back();
      params_->adaptiveThreshWinSizeStep = windows.size() > 1 ? std::max(1, windows[1] - windows[0]) : 1;
    } else {
      params_->adaptiveThreshWinSizeMin = windows[call];
      params_->adaptiveThreshWinSizeMax = windows[call];
      params_->adaptiveThreshWinSizeStep = 1;
    }
    corners_.clear();
    ids_.clear();
    rejected_.clear();
    cv::aruco::detectMarkers(image, dictionary_, corners_, ids_, params_, rejected_);
    // A pixel centre x at scale s is s*x + (s-1)/2 at full scale. OpenCV's polygon runs
    // through the centres of the outermost dark pixels, at least half a pixel (s/2 at full
    // scale) inside the black square's edge, more where a thin white margin blurs into a
    // dark floor at a coarse scale: there each edge is moved out by that half pixel. From
    // the polygon itself, the edge refinement's profiles (+-0.45 cell) missed the edges of
    // 24 px markers found at half scale (bench_perception "5s": 4 of 300 fell back to
    // cornerSubPix with 1.3-5.8 px errors, 3 could not be read at all). At full resolution
    // the half pixel is well inside the profiles and the polygon is left as it is.
    auto to_full = [&](const std::vector<cv::Point2f>& q, Candidate& c) {
      c.scale = s;
      for (std::size_t k = 0; k < 4; ++k) {
        c.corners[k] = {q[k].x * s + (s - 1) * 0.5 + offset.x, q[k].y * s + (s - 1) * 0.5 + offset.y};
      }
      if (s > 1) offset_edges(c.corners, 0.5 * s);
    };
    for (std::size_t i = 0; i < ids_.size(); ++i) {
      Candidate c;
      c.id = ids_[i];
      to_full(corners_[i], c);
      out.push_back(c);
    }
    for (const auto& q : rejected_) {
      if (q.size() != 4) continue;
      Candidate c;
      to_full(q, c);
      if ((c.side() - (s > 1 ? s : 0)) / s > kRereadBelowCoarsePx) continue;
      c.decoded_at_full_resolution = true;
      out.push_back(c);
    }
  }
}

void drop_duplicates(std::vector<Candidate>& candidates) {
  // Decoded by OpenCV first, then decoded by us, then undecoded.
  std::stable_sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    auto rank = [](const Candidate& c) { return c.id < 0 ? 2 : c.decoded_at_full_resolution ? 1 : 0; };
    return rank(a) != rank(b) ? rank(a) < rank(b) : a.scale < b.scale;
  });
  std::vector<Candidate> kept;
  kept.reserve(candidates.size());
  for (const auto& c : candidates) {
    const Point2 pc = centre(c);
    bool dup = false;
    for (const auto& k : kept) {
      const Point2 pk = centre(k);
      dup = dup ||
            ((c.id == k.id || c.id < 0) && std::hypot(pc.x - pk.x, pc.y - pk.y) < 0.25 * std::min(c.side(), k.side()));
    }
    if (!dup) kept.push_back(c);
  }
  candidates = std::move(kept);
}

}  // namespace ips::detail
