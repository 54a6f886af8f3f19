#include "verify.h"

#include <algorithm>
#include <cmath>

#include "cell_grid.h"

namespace ips::detail {
namespace {

// Rotates a row-major n x n pattern by 90 degrees (clockwise in image coordinates).
std::vector<std::uint8_t> rotate90(const std::vector<std::uint8_t>& p, int n) {
  std::vector<std::uint8_t> r(p.size());
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x)
      r[static_cast<std::size_t>(x * n + (n - 1 - y))] = p[static_cast<std::size_t>(y * n + x)];
  }
  return r;
}

}  // namespace

CodeBook::CodeBook(const cv::aruco::Dictionary& dict) : bits(dict.markerSize) {
  codes.resize(static_cast<std::size_t>(dict.bytesList.rows));
  for (int id = 0; id < dict.bytesList.rows; ++id) {
    const cv::Mat m = cv::aruco::Dictionary::getBitsFromByteList(dict.bytesList.row(id), bits);
    auto& rot = codes[static_cast<std::size_t>(id)];
    rot[0].assign(m.begin<std::uint8_t>(), m.end<std::uint8_t>());
    for (int r = 1; r < 4; ++r) rot[static_cast<std::size_t>(r)] = rotate90(rot[static_cast<std::size_t>(r - 1)], bits);
  }
}

int decode_marker(const cv::Mat& gray, std::array<Point2, 4>& corners, const cv::aruco::Dictionary& dict,
                  const CellCheck& check, bool* contrasted) {
  const int n = dict.markerSize, cells = n + 2;
  const CellReading r = read_cells(gray, corners, cells);
  if (contrasted != nullptr) *contrasted = r.ok && r.contrast() >= check.min_contrast;
  if (!r.ok || r.contrast() < check.min_contrast) return -1;
  const double mid = r.mid();
  int border_white = 0;
  cv::Mat bits(n, n, CV_8UC1);
  for (int y = 0; y < cells; ++y) {
    for (int x = 0; x < cells; ++x) {
      const double v = r.values[static_cast<std::size_t>(y * cells + x)];
      if (v < 0) return -1;
      const bool white = v > mid;
      if (y == 0 || x == 0 || y == cells - 1 || x == cells - 1) {
        border_white += white;
      } else {
        bits.at<std::uint8_t>(y - 1, x - 1) = white ? 1 : 0;
      }
    }
  }
  if (border_white > check.max_border_error_rate * (4 * cells - 4)) return -1;
  int id = -1, rotation = 0;
  if (!dict.identify(bits, id, rotation, check.error_correction_rate)) return -1;
  // As OpenCV does: the code was read `rotation` quarter turns from its printed orientation.
  std::rotate(corners.begin(), corners.begin() + 4 - rotation, corners.end());
  return id;
}

int count_ambiguous_cells(const cv::Mat& gray, const std::array<Point2, 4>& corners, int cells, double ambiguity,
                          double min_contrast) {
  const CellReading r = read_cells(gray, corners, cells);
  if (!r.ok || r.contrast() < min_contrast) return cells * cells;
  int ambiguous = 0;
  for (double v : r.values) ambiguous += v < 0 || std::abs(v - r.mid()) < ambiguity * r.contrast();
  return ambiguous;
}

bool verify_marker(const cv::Mat& gray, const std::array<Point2, 4>& corners, int id, const CodeBook& book,
                   const CellCheck& check) {
  const int n = book.bits, cells = n + 2;
  const CellReading r = read_cells(gray, corners, cells);
  if (!r.ok || r.contrast() < check.min_contrast) return false;
  // 0 = black, 1 = white, -1 = ambiguous (an erasure).
  std::vector<int> read(r.values.size());
  int ambiguous = 0;
  for (std::size_t i = 0; i < r.values.size(); ++i) {
    const double v = r.values[i];
    if (v < 0 || std::abs(v - r.mid()) < check.ambiguity * r.contrast()) {
      read[i] = -1;
      ++ambiguous;
    } else {
      read[i] = v > r.mid() ? 1 : 0;
    }
  }
  if (ambiguous <= check.max_ambiguous_cells) return true;
  if (id < 0 || id >= static_cast<int>(book.codes.size())) return false;
  // Many ambiguous cells: accept only if the clear ones leave no doubt about the code.
  int ambiguous_bits = 0;
  for (int y = 0; y < cells; ++y) {
    for (int x = 0; x < cells; ++x) {
      const int v = read[static_cast<std::size_t>(y * cells + x)];
      const bool border = y == 0 || x == 0 || y == cells - 1 || x == cells - 1;
      if (border && v == 1) return false;  // a clearly white border cell
      if (!border && v < 0) ++ambiguous_bits;
    }
  }
  if (2 * ambiguous_bits > n * n) return false;
  auto mismatches = [&](const std::vector<std::uint8_t>& code, int stop) {
    int m = 0;
    for (int y = 0; y < n && m < stop; ++y) {
      for (int x = 0; x < n; ++x) {
        const int v = read[static_cast<std::size_t>((y + 1) * cells + x + 1)];
        m += v >= 0 && v != code[static_cast<std::size_t>(y * n + x)];
      }
    }
    return m;
  };
  if (mismatches(book.codes[static_cast<std::size_t>(id)][0], 1) > 0) return false;
  for (std::size_t k = 0; k < book.codes.size(); ++k) {
    for (std::size_t rot = 0; rot < 4; ++rot) {
      if (static_cast<int>(k) == id && rot == 0) continue;
      if (mismatches(book.codes[k][rot], check.min_clear_margin) < check.min_clear_margin) return false;
    }
  }
  return true;
}

}  // namespace ips::detail
