// Decoding and verification of a marker from its full-resolution corners (internal to detect/).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/aruco.hpp>
#include <opencv2/core.hpp>

#include "ips/core/observation.h"

namespace ips::detail {

/// Every code of a dictionary in each of its four rotations, one byte per bit (1 = white),
/// row-major markerSize x markerSize: what a square read as this dictionary could be.
struct CodeBook {
  int bits = 0;                                                 ///< markerSize
  std::vector<std::array<std::vector<std::uint8_t>, 4>> codes;  ///< [id][rotation]
  explicit CodeBook(const cv::aruco::Dictionary& dict);
};

struct CellCheck {
  double ambiguity = 0.2;       ///< |value - mid| < ambiguity x contrast: ambiguous cell
  int max_ambiguous_cells = 2;  ///< more than this: the code must single out the id
  double min_contrast = 25;     ///< grey levels between border and quiet zone, at least
  int min_clear_margin = 2;     ///< clear cells on which every other code must differ
  double error_correction_rate = 0.6;
  double max_border_error_rate = 0.35;
};

/// Reads a candidate square at full resolution (cells thresholded midway between its black
/// border and white quiet zone) and identifies it in `dict`. On success returns the id and
/// rotates `corners` into ArUco order (corner 0 = the printed marker's top-left); -1 if it
/// is not a marker of the dictionary. `contrasted` (optional) tells whether the square had
/// the contrast of a marker between its border and quiet zone (worth refining and reading
/// again when the corners were coarse).
int decode_marker(const cv::Mat& gray, std::array<Point2, 4>& corners, const cv::aruco::Dictionary& dict,
                  const CellCheck& check, bool* contrasted = nullptr);

/// Accepts a decoded marker (corners in ArUco order) when its cells read clearly: at most
/// `max_ambiguous_cells` cells within `ambiguity` x contrast of mid-grey. A genuine marker
/// seen obliquely or blurred can have more (narrow cells lose contrast): it is still
/// accepted when the ambiguous cells cannot change what it is - every clear cell agrees
/// with the code of `id` (black border included), at most half the bits are ambiguous, and
/// every other code of the dictionary (any rotation, the id's own other rotations too)
/// disagrees with at least `min_clear_margin` clear bits. A square of another grid read as
/// this dictionary (a 6x6 marker seen as 4x4) has cells straddling printed cells whose
/// clear remainder does not single out one code; it is refused, as is a marker with less
/// than `min_contrast` between border and quiet zone.
bool verify_marker(const cv::Mat& gray, const std::array<Point2, 4>& corners, int id, const CodeBook& book,
                   const CellCheck& check);

/// Number of ambiguous cells as defined above (cells*cells when the contrast is too low);
/// for tests and diagnostics.
int count_ambiguous_cells(const cv::Mat& gray, const std::array<Point2, 4>& corners, int cells, double ambiguity,
                          double min_contrast);

}  // namespace ips::detail
