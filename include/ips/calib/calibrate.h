// Intrinsic calibration from ChArUco observations: OpenCV's fisheye (cv::fisheye::calibrate)
// or pinhole (cv::calibrateCamera, rational model) fit, outlier views dropped and named, and
// the numbers a person needs to judge the result (RMS, per-view RMS, coverage of the image,
// largest field angle covered, where a fitted fisheye polynomial turns back).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/calib/board.h"
#include "ips/calib/charuco.h"
#include "ips/geometry/camera_model.h"

namespace ips::calib {

struct CalibrationOptions {
  CameraModel::Kind kind = CameraModel::Kind::kFisheye;
  bool thin_prism = false;  ///< pinhole: add the thin-prism terms s1..s4 (12 coefficients)
  int min_views = 6;        ///< views with a usable board needed (after dropping outliers)
  int min_corners = 8;      ///< corners a view needs to be used
  /// A view is an outlier when its median corner residual is above factor x the median of
  /// all views' median residuals, and above that median + floor (a single bad corner does
  /// not make a view an outlier; it is removed on its own, see below).
  double outlier_factor = 3.0;
  double outlier_floor_px = 0.4;
  double corner_outlier_factor = 6.0;     ///< a corner is an outlier above factor x the RMS
  double corner_outlier_floor_px = 0.75;  ///< ... and above this
  bool drop_outliers = true;
};

struct ViewResult {
  std::string name;
  int corners = 0;                        ///< corners found
  int corners_dropped = 0;                ///< of them, removed as outliers (far off the fit)
  double rms = 0.0;                       ///< per-view RMS reprojection error, pixels (of the final model)
  bool used = false;                      ///< false: dropped as an outlier (or unusable, see `why`)
  std::string why;                        ///< why it was not used
  cv::Vec3d rvec, tvec;                   ///< board pose (used views)
  std::vector<cv::Point2d> px, residual;  ///< observed corners and observed - projected
};

struct CalibrationResult {
  CameraModel model;
  double rms = 0.0;  ///< over all corners of the used views, pixels
  int used_views = 0;
  std::vector<ViewResult> views;  ///< every input observation, in input order
  double coverage = 0.0;          ///< fraction of the coverage grid's cells holding a corner
  cv::Size grid;                  ///< coverage grid, cells
  std::vector<int> grid_counts;   ///< corners per cell (row-major)
  double max_field_deg = 0.0;     ///< largest angle from the optical axis of a used corner
  /// Fisheye: angle where the fitted polynomial turns back (no ray beyond), if < 90 deg.
  std::optional<double> turn_back_deg;
  double turn_back_radius_px = 0.0;  ///< image radius (from the principal point) of that angle
  int corners_without_ray = 0;       ///< used corners the fitted model cannot map to a ray
};

/// Calibrates. Throws ips::InputError when there are too few usable views (naming the
/// numbers) or the images differ in size (naming two of them).
CalibrationResult calibrate(const std::vector<BoardObservation>& observations, const Board& board,
                            const CalibrationOptions& options);

/// Plain OpenCV on the same corners (every usable view, no outlier handling): the baseline
/// a calibration must not be worse than.
CameraModel calibrate_opencv_plain(const std::vector<BoardObservation>& observations, const Board& board,
                                   CameraModel::Kind kind, int min_corners = 8, bool thin_prism = false);

/// Coverage grid used by the reports and the live mode: about 16 cells across, square cells.
cv::Size coverage_grid(cv::Size image);

/// How far `estimate` projects from `truth`: for every pixel on a `step`-pixel grid within
/// `radius_px` of one of `points` (the field the views covered), the truth's ray is projected
/// by the estimate; returns {max, rms} of the pixel distance and the number of pixels checked.
struct ModelDifference {
  double max_px = 0.0, rms_px = 0.0;
  int pixels = 0;
  cv::Point2d worst;  ///< pixel of the largest difference
};
ModelDifference compare_models(const CameraModel& truth, const CameraModel& estimate,
                               const std::vector<cv::Point2d>& points, double radius_px = 25.0, int step = 8);

/// A camera model in the ipsd intrinsics YAML form (what CameraModel::load reads).
std::string model_yaml(const CameraModel& model);

/// Writes the intrinsics in the ipsd YAML form (CameraModel::load reads it) with a
/// `calibration:` block recording the board, image counts, RMS, coverage and date.
std::string intrinsics_yaml(const CalibrationResult& result, const BoardSpec& board, const std::string& source);

/// The `--json` numbers.
std::string result_json(const CalibrationResult& result, const BoardSpec& board);

/// The report picture: the image area with the coverage grid, every used corner and its
/// residual vector magnified `magnify` times, dropped views' corners in red, the numbers.
cv::Mat draw_report(const CalibrationResult& result, const BoardSpec& board, double magnify);

}  // namespace ips::calib
