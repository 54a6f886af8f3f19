// Rejects decodes whose cells are not uniformly black or white (internal to detect/).
#pragma once

#include <array>

#include <opencv2/core.hpp>

#include "ips/observation.h"

namespace ips::detail {

/// Samples the centre of every cell of a marker (`cells` x `cells` including the border)
/// through the homography of its refined corners, plus the white quiet zone around it, and
/// counts the cells whose grey level lies within `ambiguity` x contrast of the mid level
/// between black (border cells) and white (quiet zone). A real marker has sharp uniform
/// cells; a square of a different grid read as this dictionary (a 6x6 marker seen as 4x4)
/// has cells that straddle two printed cells and read mid-grey. Returns the count, or
/// cells*cells when the contrast is below `min_contrast` grey levels.
int count_ambiguous_cells(const cv::Mat& gray, const std::array<Point2, 4>& corners, int cells,
                          double ambiguity, double min_contrast);

}  // namespace ips::detail
