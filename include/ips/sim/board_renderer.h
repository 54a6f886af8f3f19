// Renders the ChArUco calibration board at any 6-DoF pose in front of a scene camera, with
// exact truth (board pose, corner pixels), through the same camera model, ray map, vignetting
// and sensor noise as the scene renderer (renderer.h); the floor seen behind the board is
// that camera's floor. Used by `ips sim board-views` and the calibration tests.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "ips/calib/board.h"
#include "ips/core/observation.h"
#include "ips/sim/renderer.h"

namespace ips::sim {

/// Board frame -> camera frame: p_cam = R * p_board + t (metres, OpenCV camera axes).
struct BoardPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d(0, 0, 1);
};

/// How one view looks besides its pose.
struct BoardLook {
  double blur_sigma = 0.0;    ///< Gaussian defocus, pixels (0 = sharp)
  double gradient = 0.0;      ///< lighting across the board: brightness 1 +- gradient/2
  double gradient_dir = 0.0;  ///< direction of that gradient in the board plane, radians
};

/// Exact truth of one view.
struct BoardTruth {
  std::vector<Point2> corners_px;  ///< per ChArUco corner id: exact projection
  std::vector<bool> visible;       ///< in front, inside the lens' field, >= 4 px inside the image
  int visible_count = 0;
};

class BoardRenderer {
 public:
  /// White paper around the printed board, metres on each side.
  BoardRenderer(const CameraRenderer& camera, const calib::Board& board, double paper_margin);

  /// Renders the board over the camera's floor into `gray` (CV_8UC1, reused), then blur,
  /// then the scene's sensor noise (JPEG is the caller's: encode_jpeg).
  void render(const BoardPose& pose, const BoardLook& look, cv::Mat& gray, std::uint64_t noise_index) const;
  BoardTruth truth(const BoardPose& pose) const;

  const CameraRenderer& camera() const { return camera_; }
  const calib::Board& board() const { return board_; }

 private:
  const CameraRenderer& camera_;
  const calib::Board& board_;
  double margin_;
};

/// Settings of the pose generator (see generate_board_views).
struct BoardViewOptions {
  int views = 30;
  double tilt_min_deg = 10.0, tilt_max_deg = 50.0;  ///< board normal vs. the line of sight
  double size_min = 0.30, size_max = 0.55;          ///< board width / image width, on the optical axis
  double min_visible = 0.85;                        ///< fraction of the corners that must be visible
  double max_blur = 0.6;                            ///< defocus sigma drawn from [0, this], pixels
  double max_gradient = 0.3;                        ///< lighting gradient drawn from [0, this]
  unsigned seed = 1;
};

struct BoardView {
  BoardPose pose;
  BoardLook look;
  BoardTruth truth;
};

/// Poses that spread the board over the image and over tilts, the way a person should
/// calibrate: the image is divided into a grid of about `views` cells (aspect-matched); view
/// k aims the board's centre at a random point of cell k (the image's corner cells first, then
/// its edge cells, then the inside, each group in random order; cells whose centre has no ray
/// skipped), at a distance that makes the board 30-55 % of the image
/// width, faces it to the camera, rolls it by +-45 deg and tilts it by 10-50 deg about a
/// random in-plane axis. A pose is kept if >= 85 % of the corners are visible and the board
/// is not seen edge-on (< 70 deg); otherwise it is redrawn, moving towards the image centre.
std::vector<BoardView> generate_board_views(const BoardRenderer& renderer, const BoardViewOptions& options);

}  // namespace ips::sim
