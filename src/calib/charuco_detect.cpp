#include "ips/calib/charuco.h"

#include <algorithm>
#include <cmath>

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

namespace ips::calib {

int refine_window(double d) { return std::min(12, static_cast<int>(std::floor(d / std::sqrt(2.0) - 1.5))); }

BoardObservation detect_board(const cv::Mat& gray, const Board& board) {
  BoardObservation obs;
  obs.image_size = gray.size();
  std::vector<std::vector<cv::Point2f>> marker_corners, rejected;
  std::vector<int> marker_ids;
  auto params = cv::aruco::DetectorParameters::create();
  // Marker corners only seed the interpolation; the chessboard corners are refined below.
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  cv::aruco::detectMarkers(gray, board.charuco()->dictionary, marker_corners, marker_ids, params, rejected);
  // Keep only markers of this board (a robot's marker of another id range is not ours).
  {
    std::vector<std::vector<cv::Point2f>> c2;
    std::vector<int> i2;
    const auto& ids = board.charuco()->ids;
    for (std::size_t i = 0; i < marker_ids.size(); ++i) {
      if (std::find(ids.begin(), ids.end(), marker_ids[i]) != ids.end()) {
        c2.push_back(marker_corners[i]);
        i2.push_back(marker_ids[i]);
      }
    }
    marker_corners.swap(c2);
    marker_ids.swap(i2);
  }
  obs.markers = static_cast<int>(marker_ids.size());
  if (marker_ids.empty()) return obs;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board.charuco(), corners, ids);
  if (ids.empty()) return obs;
  // Refine every interpolated corner with its own window, clear of the marker corners.
  for (std::size_t i = 0; i < ids.size(); ++i) {
    double d = 1e18;
    for (const auto& m : marker_corners)
      for (const auto& c : m) d = std::min(d, static_cast<double>(std::hypot(c.x - corners[i].x, c.y - corners[i].y)));
    const int w = refine_window(d);
    if (w < 2) continue;
    std::vector<cv::Point2f> p{corners[i]};
    cv::cornerSubPix(gray, p, cv::Size(w, w), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
    if (std::hypot(p[0].x - corners[i].x, p[0].y - corners[i].y) > std::max(2.0, 0.5 * w)) continue;
    obs.ids.push_back(ids[i]);
    obs.px.emplace_back(p[0].x, p[0].y);
    obs.window.push_back(w);
  }
  return obs;
}

}  // namespace ips::calib
