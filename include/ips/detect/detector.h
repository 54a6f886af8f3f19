// ArUco marker detection for images of any size, tuned for 1080p overhead fisheye frames.
//
// Steps of Detector::detect() (see plan_detection for the scale):
//   1. downscale the greyscale frame (or a region of it) by the detection scale (area
//      averaging);
//   2. OpenCV ArUco (4.6 contrib API) candidate search + decoding on the small image, with
//      only the adaptive-threshold window sizes listed (the default parameters run three
//      passes at full resolution, which is most of their cost); candidate squares OpenCV
//      could not decode at that scale (small markers have cells of 2-3 px there) are read
//      again at full resolution; a full-resolution pass for markers too small for the
//      coarse scale when an explicit scale asks for it (multi-scale);
//   3. map the corners back to full resolution and refine them there, so sub-pixel accuracy
//      does not depend on the detection scale: by default by fitting the four edges (see
//      CornerRefinement), otherwise with cv::cornerSubPix;
//   4. verify every marker's cells at full resolution (see DetectorOptions::max_ambiguous_cells).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/core/observation.h"
#include "ips/geometry/camera_model.h"

namespace ips {

enum class CornerRefinement {
  /// Locate each edge at many points (mid-grey crossing across the edge), fit a line per
  /// edge (in undistorted coordinates when a CameraModel is given, where a flat marker's
  /// edges are straight), intersect. Unbiased on blurred L-corners; falls back to kSubPix
  /// for a marker whose edges cannot all be measured.
  kEdges,
  /// cv::cornerSubPix: biased by ~0.15-0.2 px towards the inside of blurred L-corners.
  kSubPix,
  /// The detection-scale polygon corners (~detect_scale px accuracy).
  kNone,
};

struct DetectorOptions {
  /// OpenCV predefined dictionary name (DICT_4X4_50 ... DICT_ARUCO_ORIGINAL, DICT_APRILTAG_*).
  std::string dictionary = "DICT_4X4_100";
  /// The smallest marker to find: its side (perimeter / 4) in full-resolution pixels.
  /// 0 = automatic: 16 px, or 1/80 of the image's larger side where that is more (24 px at
  /// 1920x1080, where 7.5 cm markers at the edge of a fisheye view at 2.1 m are 24-35 px).
  /// OpenCV's default limit also grows with the image (1/133 of its larger side).
  double min_marker_px = 0;
  /// Candidate search on the image shrunk by this integer factor; 0 = automatic: the largest
  /// factor at which the smallest marker still measures kMinCoarseMarkerPx (12 px): 2 at
  /// 1920x1080 (a quarter of the threshold/contour cost), 1 at 1280x960 and below. An
  /// explicit factor too coarse for min_marker_px adds a full-resolution pass for the
  /// markers below kMinCoarseMarkerPx x factor.
  int detect_scale = 0;
  /// Adaptive-threshold window sizes (odd, pixels at the detection scale), one threshold +
  /// contour pass each (~1.5 ms per window at 960x540). OpenCV's default is 3, 13, 23 at
  /// full resolution (three passes). One 9 px window at half scale (18 px at full scale)
  /// marks a band along every dark/bright edge, which outlines markers of 40-200 px under
  /// smooth lighting gradients; add e.g. 19 for strongly uneven or very blurred images.
  std::vector<int> threshold_windows = {9};
  /// Constant subtracted from the local mean in adaptive thresholding, grey levels (OpenCV default
  /// 7).
  double threshold_constant = 7.0;
  /// Largest marker perimeter, as a fraction of the larger image side (OpenCV default 4).
  double max_perimeter_rate = 4.0;
  /// Fraction of the dictionary's correctable bits accepted when decoding (OpenCV default 0.6).
  /// Lower rejects more false positives, higher recovers more damaged markers.
  double error_correction_rate = 0.6;
  /// Fraction of the border cells allowed to read white (OpenCV default 0.35). Lower rejects
  /// more non-marker squares, higher tolerates blur and glare on the border.
  double max_border_error_rate = 0.35;
  /// Verification after decoding: a cell whose centre reads within `cell_ambiguity` x
  /// contrast of the black/white mid level is ambiguous; a marker with more than
  /// `max_ambiguous_cells` of them is kept only when its clear cells alone single out its
  /// code (all agree with it, and every other code of the dictionary in any rotation
  /// differs from them in at least `min_clear_margin` cells): blur and a grazing view grey
  /// out narrow cells of a genuine marker, while a square of another grid (a 6x6 marker
  /// misread as 4x4) leaves clear cells that fit no code so well. Negative max disables the
  /// check.
  int max_ambiguous_cells = 2;
  double cell_ambiguity = 0.2;
  int min_clear_margin = 2;
  /// A marker whose black border and white quiet zone differ by less than this many grey
  /// levels is rejected by the verification.
  double min_contrast = 25.0;
  /// How corners are refined at full resolution.
  CornerRefinement refinement = CornerRefinement::kEdges;
  /// Half-size of the cv::cornerSubPix search window at full resolution, pixels: the window
  /// is (2w+1)^2. Must exceed the detection-scale corner error (~detect_scale px) and stay
  /// below a marker cell (a 40 px marker of 6 cells has ~6.7 px cells). Default 4.
  int refine_half_window_px = 4;
  /// cornerSubPix stops after this many iterations or when a corner moves < refine_epsilon_px.
  int refine_max_iterations = 30;
  double refine_epsilon_px = 0.005;

  bool operator==(const DetectorOptions&) const = default;
};

class Detector {
 public:
  /// Throws ips::InputError for an unknown dictionary name or an invalid option.
  explicit Detector(const DetectorOptions& options = {});
  ~Detector();
  Detector(Detector&&) noexcept;
  Detector& operator=(Detector&&) noexcept;

  /// Finds markers in an 8-bit greyscale image; corners refined to sub-pixel accuracy at
  /// full resolution. `camera` (optional, the image's intrinsics) lets edge refinement fit
  /// straight lines in undistorted coordinates. Not thread-safe (reuses buffers); use one
  /// Detector per thread.
  std::vector<MarkerDetection> detect(const cv::Mat& gray, const CameraModel* camera = nullptr);

  /// The same steps on the sub-rectangle `roi` of the full-resolution image (e.g. around a
  /// marker predicted by tracking): candidates are searched inside `roi` only (no copy: a
  /// view of `gray`), refinement and verification read the full image, corners are in
  /// full-image coordinates, and the detection scale and marker-size limits are those of
  /// the full image (plan_detection(options, gray.size())), so a marker found in an ROI has
  /// the corners a full-frame search would give it. `roi` is clipped to the image.
  std::vector<MarkerDetection> detect(const cv::Mat& gray, const cv::Rect& roi, const CameraModel* camera = nullptr);

  /// Tracking's shortcut for a marker known from the previous frame (DetectionTracker): no
  /// candidate search; `predicted` (its id and corners in ArUco order, predicted for this
  /// image) is refined by the full search's edge refinement (its two passes), and the result
  /// is kept only if it reads as `predicted.id` in the same orientation (the full-resolution
  /// decoding) and passes the full search's verification: a marker the full search would
  /// refuse is refused here too. False (the caller then searches around it) when the
  /// prediction is too far off for the edge profiles (~3 px across an edge, 4 px per corner
  /// and pass), the refinement is not kEdges, or the marker is not read. Reads only pixels
  /// within one cell + 4 px of the predicted and refined corners, and only inside `valid`
  /// (false if they leave it): a partial decode is enough.
  bool refine_known(const cv::Mat& gray, const MarkerDetection& predicted, const cv::Rect& valid,
                    const CameraModel* camera, MarkerDetection& out);

  const DetectorOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Smallest marker side (px, at the detection scale) the candidate search finds reliably:
/// the automatic scale keeps min_marker_px at or above it.
inline constexpr double kMinCoarseMarkerPx = 12.0;

/// What detect() does on an image of a given size.
struct DetectionPlan {
  double min_marker_px = 0;           ///< smallest marker side searched, full-resolution px
  int scale = 1;                      ///< candidate-search scale factor
  bool full_resolution_pass = false;  ///< markers below kMinCoarseMarkerPx x scale searched at 1
};
DetectionPlan plan_detection(const DetectorOptions& options, cv::Size image);

/// The OpenCV dictionary id for a name such as "DICT_4X4_100". Throws ips::InputError
/// listing the known names.
int dictionary_id(const std::string& name);

}  // namespace ips
