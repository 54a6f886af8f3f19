#include "ips/detect/detector.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "candidates.h"
#include "edge_refine.h"
#include "ips/core/error.h"
#include "verify.h"

namespace ips {
namespace {

const std::vector<std::pair<const char*, int>>& dictionary_names() {
  static const std::vector<std::pair<const char*, int>> names = {
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
      {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
      {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
      {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
      {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
      {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
      {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
      {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
      {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
      {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
      {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
      {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
      {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
      {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
      {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
      {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
      {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
  };
  return names;
}

// The automatic smallest marker: 16 px (a 6x6 marker's cells are then 2 px, about the least
// that can be read), growing with the image like OpenCV's own default limit.
constexpr double kAutoMinMarkerPx = 16.0;
constexpr double kAutoMinMarkerFraction = 1.0 / 80.0;

}  // namespace

int dictionary_id(const std::string& name) {
  std::string known;
  for (const auto& [n, id] : dictionary_names()) {
    if (name == n) return id;
    known += known.empty() ? n : std::string(", ") + n;
  }
  throw InputError("unknown ArUco dictionary '" + name + "' (known: " + known + ")");
}

DetectionPlan plan_detection(const DetectorOptions& o, cv::Size image) {
  DetectionPlan p;
  const double side = std::max(image.width, image.height);
  p.min_marker_px = o.min_marker_px > 0 ? o.min_marker_px : std::max(kAutoMinMarkerPx, kAutoMinMarkerFraction * side);
  p.scale = o.detect_scale > 0 ? o.detect_scale
                               : std::clamp(static_cast<int>(std::floor(p.min_marker_px / kMinCoarseMarkerPx)), 1, 8);
  p.full_resolution_pass = p.scale > 1 && p.min_marker_px < kMinCoarseMarkerPx * p.scale;
  return p;
}

struct Detector::Impl {
  DetectorOptions options;
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  std::unique_ptr<detail::CodeBook> codes;
  detail::CellCheck check;
  detail::CandidateSearch search;
  std::vector<detail::Candidate> candidates, local;
  std::vector<cv::Point2f> refine;
};

Detector::Detector(const DetectorOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  const auto& o = impl_->options;
  if (o.detect_scale < 0 || o.detect_scale > 8) {
    throw InputError("detector: detect_scale must be 0 (automatic) or 1..8, got " + std::to_string(o.detect_scale));
  }
  if (!(o.min_marker_px >= 0) || !std::isfinite(o.min_marker_px)) {
    throw InputError("detector: min_marker_px must be 0 (automatic) or a positive size in pixels");
  }
  if (o.threshold_windows.empty()) throw InputError("detector: threshold_windows is empty");
  for (int w : o.threshold_windows) {
    if (w < 3 || w % 2 == 0) {
      throw InputError("detector: threshold window sizes must be odd and >= 3, got " + std::to_string(w));
    }
  }
  if (o.refine_half_window_px < 1) throw InputError("detector: refine_half_window_px must be >= 1");
  if (!(o.max_perimeter_rate > 0)) throw InputError("detector: max_perimeter_rate must be positive");
  if (o.min_clear_margin < 1) throw InputError("detector: min_clear_margin must be >= 1");
  impl_->dictionary = cv::aruco::getPredefinedDictionary(dictionary_id(o.dictionary));
  impl_->codes = std::make_unique<detail::CodeBook>(*impl_->dictionary);
  auto& c = impl_->check;
  c.ambiguity = o.cell_ambiguity;
  c.max_ambiguous_cells = o.max_ambiguous_cells;
  c.min_contrast = o.min_contrast;
  c.min_clear_margin = o.min_clear_margin;
  c.error_correction_rate = o.error_correction_rate;
  c.max_border_error_rate = o.max_border_error_rate;
  impl_->search.configure(o, impl_->dictionary);
}

Detector::~Detector() = default;
Detector::Detector(Detector&&) noexcept = default;
Detector& Detector::operator=(Detector&&) noexcept = default;

const DetectorOptions& Detector::options() const { return impl_->options; }

std::vector<MarkerDetection> Detector::detect(const cv::Mat& gray, const CameraModel* camera) {
  return detect(gray, cv::Rect(0, 0, gray.cols, gray.rows), camera);
}

std::vector<MarkerDetection> Detector::detect(const cv::Mat& gray, const cv::Rect& roi_in, const CameraModel* camera) {
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw InputError("detector: expected a non-empty 8-bit greyscale image");
  }
  Impl& d = *impl_;
  const auto& o = d.options;
  const cv::Rect roi = roi_in & cv::Rect(0, 0, gray.cols, gray.rows);
  std::vector<MarkerDetection> out;
  if (roi.width < 8 || roi.height < 8) return out;
  const DetectionPlan plan = plan_detection(o, gray.size());
  const int cells = d.dictionary->markerSize + 2;
  // OpenCV's search at full resolution around a square found at a coarse scale (its
  // bounding box with half a side of margin), into d.local: where the coarse polygon is too
  // far off for the edge profiles (a corner cut by the polygon approximation of a 12-15 px
  // square), the full-resolution polygon is within a pixel. A ~60 px region costs little
  // next to the full search.
  auto search_near = [&](const detail::Candidate& c) {
    d.local.clear();
    double x0 = c.corners[0].x, x1 = x0, y0 = c.corners[0].y, y1 = y0;
    for (const auto& q : c.corners) {
      x0 = std::min(x0, q.x);
      x1 = std::max(x1, q.x);
      y0 = std::min(y0, q.y);
      y1 = std::max(y1, q.y);
    }
    const double margin = 0.5 * c.side() + 4;
    const cv::Rect box = cv::Rect(cv::Point(static_cast<int>(x0 - margin), static_cast<int>(y0 - margin)),
                                  cv::Point(static_cast<int>(x1 + margin) + 1, static_cast<int>(y1 + margin) + 1)) &
                         cv::Rect(0, 0, gray.cols, gray.rows);
    if (box.width >= 8 && box.height >= 8) {
      d.search.run(gray(box), box.tl(), 1, plan.min_marker_px, 0.0, d.local);
    }
  };

  // 1-2. Candidate squares in the region, corners at full resolution: decoded ones with their
  // id, the others (id -1) read again below.
  d.candidates.clear();
  d.search.run(gray(roi), roi.tl(), plan.scale, plan.min_marker_px,
               plan.full_resolution_pass ? kMinCoarseMarkerPx * plan.scale : 0.0, d.candidates);
  // Indexed: squares found by the local full-resolution searches below are appended and
  // read in the same loop.
  for (std::size_t i = 0; i < d.candidates.size(); ++i) {
    detail::Candidate c = d.candidates[i];
    if (c.id >= 0) continue;
    bool contrasted = false;
    c.id = detail::decode_marker(gray, c.corners, *d.dictionary, d.check, &contrasted);
    // Coarse corners of a small square can be a third of a cell off: a square with a
    // marker's contrast is refined and read once more.
    if (c.id < 0 && contrasted && o.refinement == CornerRefinement::kEdges) {
      std::array<Point2, 4> r = c.corners;
      if (detail::refine_corners_by_edges(gray, r, cells, camera)) {
        c.id = detail::decode_marker(gray, r, *d.dictionary, d.check);
        if (c.id >= 0) c.corners = r;
      }
    }
    // Still unread with a marker's contrast: the coarse polygon may be too far off to
    // refine; the squares OpenCV finds around it at full resolution are read in this loop.
    if (c.id < 0 && contrasted && c.scale > 1) {
      search_near(c);
      d.candidates.insert(d.candidates.end(), d.local.begin(), d.local.end());
    }
    d.candidates[i] = c;
  }
  detail::drop_duplicates(d.candidates);
  out.reserve(d.candidates.size());
  std::vector<bool> reread;  // decoded by us: read again with the refined corners
  std::vector<const detail::Candidate*> source;
  for (const auto& c : d.candidates) {
    if (c.id < 0) continue;
    out.push_back({c.id, c.corners});
    reread.push_back(c.decoded_at_full_resolution);
    source.push_back(&c);
  }

  // 3. Refine at full resolution.
  d.refine.clear();
  std::vector<std::size_t> subpix;  // markers refined with cornerSubPix
  for (std::size_t i = 0; o.refinement != CornerRefinement::kNone && i < out.size(); ++i) {
    if (o.refinement == CornerRefinement::kEdges) {
      // Twice: the second pass samples along the edges found by the first.
      std::array<Point2, 4> c = out[i].corners_px;
      auto refine = [&](std::array<Point2, 4>& q) {
        return detail::refine_corners_by_edges(gray, q, cells, camera) &&
               detail::refine_corners_by_edges(gray, q, cells, camera);
      };
      if (refine(c)) {
        out[i].corners_px = c;
        continue;
      }
      // A coarse polygon the edges cannot be found from (cornerSubPix would move such a
      // small marker's corners by pixels, 1 in 1000 7.5 cm markers failed the re-read
      // then): the same marker found around it at full resolution, refined from there.
      if (source[i]->scale > 1) {
        search_near(*source[i]);
        bool done = false;
        for (auto& l : d.local) {
          c = l.corners;
          const int id = l.id >= 0 ? l.id : detail::decode_marker(gray, c, *d.dictionary, d.check);
          if (id != out[i].id || !refine(c)) continue;
          out[i].corners_px = c;
          done = true;
          break;
        }
        if (done) continue;
      }
    }
    subpix.push_back(i);
    for (const auto& c : out[i].corners_px) {
      d.refine.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
    }
  }
  if (!d.refine.empty()) {
    const int w = o.refine_half_window_px;
    cv::cornerSubPix(gray, d.refine, cv::Size(w, w), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, o.refine_max_iterations,
                                      o.refine_epsilon_px));
    for (std::size_t j = 0; j < subpix.size(); ++j) {
      for (std::size_t k = 0; k < 4; ++k) {
        const cv::Point2f& c = d.refine[j * 4 + k];
        out[subpix[j]].corners_px[k] = {c.x, c.y};
      }
    }
  }
  // 4. Verify: a marker we decoded from coarse corners must read the same with the refined
  // ones, and every marker's cells must leave no doubt about its code.
  std::vector<MarkerDetection> kept;
  kept.reserve(out.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (reread[i]) {
      std::array<Point2, 4> c = out[i].corners_px;
      if (detail::decode_marker(gray, c, *d.dictionary, d.check) != out[i].id || c[0].x != out[i].corners_px[0].x ||
          c[0].y != out[i].corners_px[0].y)
        continue;
    }
    if (o.max_ambiguous_cells >= 0 && !detail::verify_marker(gray, out[i].corners_px, out[i].id, *d.codes, d.check))
      continue;
    kept.push_back(out[i]);
  }
  return kept;
}

bool Detector::refine_known(const cv::Mat& gray, const MarkerDetection& predicted, const cv::Rect& valid,
                            const CameraModel* camera, MarkerDetection& out) {
  Impl& d = *impl_;
  const auto& o = d.options;
  if (o.refinement != CornerRefinement::kEdges || gray.empty() || gray.type() != CV_8UC1) return false;
  const int cells = d.dictionary->markerSize + 2;
  const cv::Rect area = valid & cv::Rect(0, 0, gray.cols, gray.rows);
  // Every pixel a refinement pass reads (profiles <= 3 + 1 px across the current edges) or
  // the cell reading reads (the quiet zone 0.6 cell outside the border, + 1 px bilinear)
  // lies within a cell + 4 px of the current corners: checked before each pass and after.
  auto inside = [&](const std::array<Point2, 4>& q) {
    double side = 0;
    for (std::size_t i = 0; i < 4; ++i) side += std::hypot(q[(i + 1) % 4].x - q[i].x, q[(i + 1) % 4].y - q[i].y) / 4;
    const double m = side / cells + 4;
    for (const auto& p : q) {
      if (!(p.x - m >= area.x && p.y - m >= area.y && p.x + m <= area.x + area.width - 1 &&
            p.y + m <= area.y + area.height - 1))
        return false;
    }
    return true;
  };
  std::array<Point2, 4> c = predicted.corners_px;
  // The full search's two passes (the second samples along the edges the first found), and
  // more (up to 4) while the last one still moved a corner by more than kSettledPx: each
  // pass samples along the edges the previous one found, so the result depends a little on
  // where the first started (a 30 px marker predicted 2.5 px off was 0.075 px from the full
  // search's corners after two passes, 0.003 after settling). bench_perception 5t: 84 % of
  // the markers settle in two passes, corners within 0.034 px of the full search's (0.032
  // with a 0.02 px limit, which needs a third pass for 2/3 of them).
  constexpr double kSettledPx = 0.05;
  constexpr int kMaxPasses = 4;
  for (int pass = 0;; ++pass) {
    const std::array<Point2, 4> before = c;
    if (!inside(c) || !detail::refine_corners_by_edges(gray, c, cells, camera)) return false;
    if (pass < 1) continue;
    double moved = 0;
    for (std::size_t k = 0; k < 4; ++k) moved = std::max(moved, std::hypot(c[k].x - before[k].x, c[k].y - before[k].y));
    if (moved <= kSettledPx) break;
    if (pass + 1 == kMaxPasses) return false;
  }
  if (!inside(c)) return false;
  // Read as the full search reads a square it decoded itself: the same id, in the same
  // orientation (the corners not rotated), then the same verification.
  std::array<Point2, 4> r = c;
  if (detail::decode_marker(gray, r, *d.dictionary, d.check) != predicted.id || r[0].x != c[0].x || r[0].y != c[0].y)
    return false;
  if (o.max_ambiguous_cells >= 0 && !detail::verify_marker(gray, c, predicted.id, *d.codes, d.check)) return false;
  out = {predicted.id, c};
  return true;
}

}  // namespace ips
