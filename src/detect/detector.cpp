#include "ips/detector.h"

#include <cmath>
#include <utility>

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "edge_refine.h"
#include "ips/error.h"
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

}  // namespace

int dictionary_id(const std::string& name) {
  std::string known;
  for (const auto& [n, id] : dictionary_names()) {
    if (name == n) return id;
    known += known.empty() ? n : std::string(", ") + n;
  }
  throw InputError("unknown ArUco dictionary '" + name + "' (known: " + known + ")");
}

struct Detector::Impl {
  DetectorOptions options;
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  cv::Ptr<cv::aruco::DetectorParameters> params;
  cv::Mat small;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  std::vector<cv::Point2f> refine;
  cv::Size params_for;  // image size the perimeter rates were computed for
};

Detector::Detector(const DetectorOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  const auto& o = impl_->options;
  if (o.detect_scale < 1 || o.detect_scale > 8) {
    throw InputError("detector: detect_scale must be 1..8, got " + std::to_string(o.detect_scale));
  }
  if (o.threshold_windows.empty()) throw InputError("detector: threshold_windows is empty");
  for (int w : o.threshold_windows) {
    if (w < 3 || w % 2 == 0) {
      throw InputError("detector: threshold window sizes must be odd and >= 3, got " +
                       std::to_string(w));
    }
  }
  if (o.refine_half_window_px < 1) throw InputError("detector: refine_half_window_px must be >= 1");
  if (!(o.min_perimeter_px > 0) || !(o.max_perimeter_rate > 0)) {
    throw InputError("detector: perimeter limits must be positive");
  }
  impl_->dictionary = cv::aruco::getPredefinedDictionary(dictionary_id(o.dictionary));
  auto p = cv::aruco::DetectorParameters::create();
  // A set of windows is expressed as min/max/step; arbitrary lists run one pass per entry
  // (see detect()), so the parameters hold a single window at a time.
  p->adaptiveThreshConstant = o.threshold_constant;
  p->maxMarkerPerimeterRate = o.max_perimeter_rate;
  p->errorCorrectionRate = o.error_correction_rate;
  p->maxErroneousBitsInBorderRate = o.max_border_error_rate;
  p->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;  // refined at full resolution below
  impl_->params = p;
}

Detector::~Detector() = default;
Detector::Detector(Detector&&) noexcept = default;
Detector& Detector::operator=(Detector&&) noexcept = default;

const DetectorOptions& Detector::options() const { return impl_->options; }

std::vector<MarkerDetection> Detector::detect(const cv::Mat& gray, const CameraModel* camera) {
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw InputError("detector: expected a non-empty 8-bit greyscale image");
  }
  Impl& d = *impl_;
  const auto& o = d.options;
  const int s = o.detect_scale;

  // 1. Downscale.
  const cv::Mat* work = &gray;
  if (s > 1) {
    cv::resize(gray, d.small, cv::Size(gray.cols / s, gray.rows / s), 0, 0, cv::INTER_AREA);
    work = &d.small;
  }
  d.params->minMarkerPerimeterRate =
      o.min_perimeter_px / s / static_cast<double>(std::max(work->cols, work->rows));

  // 2. Detect: windows given as an arithmetic sequence become one OpenCV call.
  std::vector<MarkerDetection> out;
  std::vector<int> windows = o.threshold_windows;
  bool arithmetic = windows.size() <= 2;
  for (std::size_t i = 2; i < windows.size(); ++i) {
    arithmetic = arithmetic && windows[i] - windows[i - 1] == windows[1] - windows[0];
  }
  if (arithmetic) {
    d.params->adaptiveThreshWinSizeMin = windows.front();
    d.params->adaptiveThreshWinSizeMax = windows.back();
    d.params->adaptiveThreshWinSizeStep =
        windows.size() > 1 ? std::max(1, windows[1] - windows[0]) : 1;
    d.corners.clear();
    d.ids.clear();
    cv::aruco::detectMarkers(*work, d.dictionary, d.corners, d.ids, d.params);
  } else {
    std::vector<std::vector<cv::Point2f>> all_corners;
    std::vector<int> all_ids;
    for (int w : windows) {
      d.params->adaptiveThreshWinSizeMin = w;
      d.params->adaptiveThreshWinSizeMax = w;
      d.params->adaptiveThreshWinSizeStep = 1;
      d.corners.clear();
      d.ids.clear();
      cv::aruco::detectMarkers(*work, d.dictionary, d.corners, d.ids, d.params);
      for (std::size_t i = 0; i < d.ids.size(); ++i) {
        bool dup = false;
        for (std::size_t j = 0; j < all_ids.size(); ++j) {
          dup = dup ||
                (all_ids[j] == d.ids[i] && cv::norm(all_corners[j][0] - d.corners[i][0]) < 3.0);
        }
        if (!dup) {
          all_ids.push_back(d.ids[i]);
          all_corners.push_back(d.corners[i]);
        }
      }
    }
    d.corners = std::move(all_corners);
    d.ids = std::move(all_ids);
  }

  // 3. Back to full resolution (a pixel centre x at scale s is s*x + (s-1)/2 at full
  // scale) and refine there.
  out.reserve(d.ids.size());
  for (std::size_t i = 0; i < d.ids.size(); ++i) {
    MarkerDetection m;
    m.id = d.ids[i];
    for (std::size_t k = 0; k < 4; ++k) {
      const cv::Point2f& c = d.corners[i][k];
      m.corners_px[k] = {c.x * s + (s - 1) * 0.5, c.y * s + (s - 1) * 0.5};
    }
    out.push_back(m);
  }
  const int cells = d.dictionary->markerSize + 2;
  d.refine.clear();
  std::vector<std::size_t> subpix;  // markers refined with cornerSubPix
  for (std::size_t i = 0; o.refinement != CornerRefinement::kNone && i < out.size(); ++i) {
    if (o.refinement == CornerRefinement::kEdges) {
      // Twice: the second pass samples along the edges found by the first.
      std::array<Point2, 4> c = out[i].corners_px;
      if (detail::refine_corners_by_edges(gray, c, cells, camera) &&
          detail::refine_corners_by_edges(gray, c, cells, camera)) {
        out[i].corners_px = c;
        continue;
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
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                      o.refine_max_iterations, o.refine_epsilon_px));
    for (std::size_t j = 0; j < subpix.size(); ++j) {
      for (std::size_t k = 0; k < 4; ++k) {
        const cv::Point2f& c = d.refine[j * 4 + k];
        out[subpix[j]].corners_px[k] = {c.x, c.y};
      }
    }
  }
  // 4. Verify: every cell must read clearly black or white.
  if (o.max_ambiguous_cells >= 0) {
    std::erase_if(out, [&](const MarkerDetection& m) {
      return detail::count_ambiguous_cells(gray, m.corners_px, cells, o.cell_ambiguity,
                                           o.min_contrast) > o.max_ambiguous_cells;
    });
  }
  return out;
}

}  // namespace ips
