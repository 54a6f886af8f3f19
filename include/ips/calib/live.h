// Choosing calibration views from a live camera: a frame is kept only when the board is
// sharp, held still, and adds something (corners in an empty part of the image, or a tilt
// that is still missing); progress says what is still missing.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/calib/board.h"
#include "ips/calib/charuco.h"

namespace ips::calib {

struct LiveOptions {
  int target_views = 30;             ///< stop after this many kept views
  double still_px = 0.7;             ///< mean corner motion since the previous frame, pixels
  double min_corner_fraction = 0.3;  ///< of the board's corners
  double sharp_fraction = 0.5;       ///< sharpness vs. the sharpest view of the board so far
  int views_per_tilt = 3;            ///< wanted views per tilt direction
};

/// The board's tilt as seen in the image, from the homography board plane -> image.
enum class Tilt { kFlat = 0, kLeftNear, kRightNear, kTopNear, kBottomNear };
const char* tilt_name(Tilt t);

class ViewSelector {
 public:
  ViewSelector(const Board& board, cv::Size image, LiveOptions options);

  struct Decision {
    bool kept = false;
    std::string reason;  ///< why not kept, or what it added
  };
  /// Offers one frame and its board observation (detect_board on the same frame).
  Decision offer(const cv::Mat& gray, const BoardObservation& obs);

  const std::vector<BoardObservation>& kept() const { return kept_; }
  bool done() const { return static_cast<int>(kept_.size()) >= options_.target_views; }
  /// What is still missing, as advice to the person holding the board ("edges of the image",
  /// "tilt the board: left edge towards the camera", ...). Empty when nothing is.
  std::vector<std::string> missing() const;
  /// Multi-line progress: views kept, the coverage grid (# = has corners), what is missing.
  std::string progress() const;
  /// Sharpness score of the board area (variance of the Laplacian over squared contrast).
  static double sharpness(const cv::Mat& gray, const BoardObservation& obs);
  Tilt tilt_of(const BoardObservation& obs) const;

 private:
  const Board& board_;
  cv::Size image_, grid_;
  LiveOptions options_;
  std::vector<int> grid_counts_;
  int tilt_counts_[5] = {0, 0, 0, 0, 0};
  std::vector<BoardObservation> kept_;
  BoardObservation previous_;
  double best_sharpness_ = 0.0;
};

}  // namespace ips::calib
