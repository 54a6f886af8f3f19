// Sub-pixel corner refinement by fitting the marker's four edges (internal to detect/).
#pragma once

#include <array>

#include <opencv2/core.hpp>

#include "ips/core/observation.h"
#include "ips/geometry/camera_model.h"

namespace ips::detail {

struct EdgeRefineOptions {
  double sample_step_px = 1.5;       ///< spacing of edge samples along each edge
  double end_margin = 0.12;          ///< fraction of each edge left out at both ends (corner blur)
  double max_profile_half_px = 3.0;  ///< half-length of the intensity profile across the edge
  double max_shift_px = 4.0;         ///< a refined corner moving further than this is rejected
};

/// Refines the 4 corners of a marker (ArUco order, any accuracy better than ~1.5 px) by
/// locating each edge to sub-pixel precision at many points (the mid-grey crossing of an
/// intensity profile across the edge, which a symmetric blur does not move), fitting a line
/// per edge and intersecting neighbouring lines. With a camera model the points are
/// undistorted first, where the edges of a flat marker are exactly straight; without one the
/// lines are fitted in pixels (fisheye curvature then costs ~0.05 px). `cells` is the
/// marker's width in cells (bits + 2 border), which bounds the profile length.
/// Returns false (corners untouched) when an edge cannot be measured.
bool refine_corners_by_edges(const cv::Mat& gray, std::array<Point2, 4>& corners, int cells, const CameraModel* camera,
                             const EdgeRefineOptions& options = {});

/// Moves each edge of a convex quadrilateral outward (away from its centre) by `d` pixels
/// along its normal; the new corners are where neighbouring moved edges meet. False (q
/// untouched) when neighbouring edges are (nearly) parallel.
bool offset_edges(std::array<Point2, 4>& q, double d);

}  // namespace ips::detail
