// Finding the ChArUco board's chessboard corners in one image (OpenCV 4.6 contrib), refined
// to sub-pixel accuracy without the two known biases of the plain OpenCV recipe:
// interpolateCornersCharuco's corners are ~0.45 px off until refined, and cornerSubPix with a
// fixed window that reaches a neighbouring marker's corner is pulled by it by 0.5-4 px. Each
// corner is therefore refined with its own window, sized from the distance to the nearest
// detected marker corner.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/calib/board.h"

namespace ips::calib {

/// The board's corners found in one image.
struct BoardObservation {
  std::string name;  ///< image file name (or "frame N" live)
  cv::Size image_size;
  int markers = 0;              ///< ArUco markers of the board found
  std::vector<int> ids;         ///< ChArUco corner ids
  std::vector<cv::Point2d> px;  ///< refined corner pixels, same order
  std::vector<int> window;      ///< cornerSubPix half-window used per corner, pixels
};

/// Detects the board in an 8-bit greyscale image. Corners whose refinement window would be
/// smaller than 2 px (board too small in the image) or whose refinement ran away are left out.
/// An image without the board gives an observation with no corners.
BoardObservation detect_board(const cv::Mat& gray, const Board& board);

/// cornerSubPix half-window for a corner whose nearest marker corner is `d` pixels away:
/// the square window must stay clear of that corner in any image orientation (d / sqrt 2),
/// less 1.5 px for the edge's blur; at most 12.
int refine_window(double nearest_marker_corner_px);

}  // namespace ips::calib
