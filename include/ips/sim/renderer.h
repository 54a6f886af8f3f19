// Renders one camera's view of a Scene with exact ground truth.
//
// Every pixel is traced through the same CameraModel the pipeline uses: the viewing ray of
// each pixel centre (exact undistort) is precomputed once; the static floor (texture,
// vignetting, lighting gradient) is rendered once into a background image. Per frame only
// the pixels inside each marker's projected bounding box are traced again, against the
// plane of the marker's face (z = height), with s x s supersampling (sub-pixel rays by
// bilinear interpolation of the pixel-centre rays, which is exact to well below 1e-3 px for
// a smooth lens model), optional motion blur (several time samples across the exposure),
// then Gaussian sensor noise from a precomputed pool, and JPEG compression on request.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "ips/core/observation.h"
#include "ips/sim/scene.h"

namespace ips::sim {

/// Exact truth for one marker in one camera at one instant.
struct MarkerTruth {
  int id = -1;
  MarkerPose pose;                     ///< world pose
  bool visible = false;                ///< all 4 corners in front of the camera and >= 3 px inside the image
  std::array<Point2, 4> corners_px{};  ///< exact projection of the black square's corners (ArUco order)
  CameraObservation formula;           ///< the depth formula applied to the exact corners: what a
                                       ///< perfect detector would report (true xc, yc, zc, yaw)
  Eigen::Vector3d centre_cam = Eigen::Vector3d::Zero();  ///< geometric marker centre, camera frame
};

/// A marker to draw: its description and the poses across the exposure (one pose = sharp).
struct PlacedMarker {
  SceneMarker marker;
  std::vector<MarkerPose> poses;
};

class CameraRenderer {
 public:
  /// Precomputes the ray map and background (~1 s of CPU at 1080p; the ray map and noise
  /// pool are cached per process and shared by renderers of the same camera). Keeps a
  /// reference to `scene`.
  CameraRenderer(const Scene& scene, std::size_t camera_index);

  /// Renders the scene's markers at scene time t (seconds) into `gray` (CV_8UC1, reused).
  /// `noise_index` selects the noise pattern (deterministic for a given index and seed).
  void render(double t, cv::Mat& gray, std::uint64_t noise_index) const;

  /// Renders an explicit set of markers (used by `ips sim collect`).
  void render_markers(const std::vector<PlacedMarker>& markers, cv::Mat& gray, std::uint64_t noise_index) const;

  /// Truth of every scene marker at time t (a riding camera where it is at t).
  std::vector<MarkerTruth> truth(double t) const;
  /// Truth of one marker at one pose (the camera where it is at t = 0).
  MarkerTruth truth_of(const SceneMarker& marker, const MarkerPose& pose) const;

  const SceneCamera& camera() const { return scene_.cameras[camera_index_]; }
  const Scene& scene() const { return scene_; }

  // The image-formation pieces, for other things drawn through the same camera (the
  // calibration board, board_renderer.h).
  /// CV_32FC2: normalised coordinates (X/Z, Y/Z) of each pixel centre's ray (NaN: no ray).
  const cv::Mat& rays() const { return *uv_; }
  /// CV_32F: vignetting x lighting gradient at each pixel.
  const cv::Mat& gain() const { return gain_; }
  /// CV_8U: the floor as this camera sees it, without markers or noise.
  const cv::Mat& background() const { return background_; }
  /// Adds the scene's sensor noise (pattern `noise_index`) to a frame of this camera.
  void add_noise(cv::Mat& gray, std::uint64_t noise_index) const;

 private:
  /// `cams`: the camera at each of the marker's poses (one: the same for all).
  void draw_marker(const PlacedMarker& m, const std::vector<SceneCamera>& cams, cv::Mat& gray) const;
  MarkerTruth truth_in(const SceneCamera& cam, const SceneMarker& marker, const MarkerPose& pose) const;

  const Scene& scene_;
  std::size_t camera_index_;
  int width_ = 0, height_ = 0;
  std::shared_ptr<const cv::Mat> uv_;  ///< CV_32FC2: normalised coords of each pixel centre (NaN: no ray)
  cv::Mat gain_;                       ///< CV_32F: vignetting x lighting gradient at each pixel
  cv::Mat background_;                 ///< CV_8U: the floor without markers or noise
  std::shared_ptr<const std::vector<std::int8_t>> noise_;  ///< Gaussian noise pool, grey levels
  std::vector<cv::Mat> patterns_;  ///< per scene marker: bits+2 cells square, 0 = black, 1 = white
};

/// JPEG-compresses a greyscale frame; `colour` stores it as a 3-channel YCbCr 4:2:0 JPEG like
/// a USB camera's MJPEG (grey chroma), otherwise as a 1-channel JPEG. Quality 1..100.
/// `restart_rows` > 0 puts a restart marker after every that many MCU rows, as some cameras
/// do (a region decode can then start at any of them: capture/jpeg_restart.h); 0, none.
std::vector<std::uint8_t> encode_jpeg(const cv::Mat& gray, int quality, bool colour, int restart_rows = 0);

/// The marker's pattern: (bits+2) x (bits+2) CV_8U cells, 0 black, 1 white. Throws
/// ips::InputError if the id is not in the dictionary.
cv::Mat marker_pattern(const std::string& dictionary, int id);

}  // namespace ips::sim
