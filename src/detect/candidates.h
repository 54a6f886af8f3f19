// Candidate squares for the detector (internal to detect/): OpenCV's contour search and
// decoding on a (downscaled) region, corners mapped to full-resolution image coordinates.
#pragma once

#include <array>
#include <vector>

#include <opencv2/aruco.hpp>
#include <opencv2/core.hpp>

#include "ips/core/observation.h"
#include "ips/detect/detector.h"

namespace ips::detail {

struct Candidate {
  int id = -1;                      ///< decoded by OpenCV at the search scale, or -1 (to be read at full resolution)
  std::array<Point2, 4> corners{};  ///< full-image pixels; ArUco order when id >= 0
  bool decoded_at_full_resolution = false;
  int scale = 1;        ///< of the search that found it (finer scales have better corners)
  double side() const;  ///< mean edge length, px
};

class CandidateSearch {
 public:
  void configure(const DetectorOptions& options, cv::Ptr<cv::aruco::Dictionary> dictionary);

  /// Searches `region` (a view of the full image whose top-left is `offset`) shrunk by
  /// `scale` for markers of side >= `min_side_px` (full-resolution px), then, if
  /// `fine_below_px` > 0, the region at full resolution for markers of `min_side_px` up to
  /// `fine_below_px` (the multi-scale case). Appends decoded markers and the undecoded
  /// squares small enough that the search scale may have been too coarse to read them.
  void run(const cv::Mat& region, cv::Point offset, int scale, double min_side_px, double fine_below_px,
           std::vector<Candidate>& out);

 private:
  void pass(const cv::Mat& image, cv::Point offset, int scale, double min_side_px, double max_side_px,
            std::vector<Candidate>& out);

  DetectorOptions options_;
  cv::Ptr<cv::aruco::Dictionary> dictionary_;
  cv::Ptr<cv::aruco::DetectorParameters> params_;
  cv::Mat small_;
  std::vector<std::vector<cv::Point2f>> corners_, rejected_;
  std::vector<int> ids_;
};

/// Removes candidates that describe the same square as an earlier one (several threshold
/// windows or scales find it; an undecoded inner contour of a marker): same id, or either
/// undecoded, and centres closer than a quarter of the side. Decoded ones win, then those
/// found at the finer scale.
void drop_duplicates(std::vector<Candidate>& candidates);

}  // namespace ips::detail
