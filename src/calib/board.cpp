#include "ips/calib/board.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/core/error.h"
#include "ips/detect/detector.h"

namespace ips::calib {
namespace {

[[noreturn]] void bad(const std::string& spec, const std::string& what) {
  throw InputError("board spec '" + spec + "': " + what +
                   " (expected charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT], e.g. " + kDefaultBoardSpec + ")");
}

double parse_length(const std::string& spec, const std::string& text, const char* name) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    bad(spec, std::string(name) + " '" + text + "' is not a number");
  }
  if (used != text.size()) bad(spec, std::string(name) + " '" + text + "' is not a number");
  if (!(v > 0.0) || !std::isfinite(v) || v > 2.0)
    bad(spec, std::string(name) + " must be in (0, 2] metres, got '" + text + "'");
  return v;
}

int parse_count(const std::string& spec, const std::string& text, const char* name) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
    bad(spec, std::string(name) + " '" + text + "' is not a whole number");
  const long v = std::stol(text);
  if (v < 3 || v > 40) bad(spec, std::string(name) + " must be 3..40 squares, got " + text);
  return static_cast<int>(v);
}

}  // namespace

BoardSpec BoardSpec::parse(const std::string& spec) {
  std::vector<std::string> parts;
  std::stringstream ss(spec);
  for (std::string p; std::getline(ss, p, ':');) parts.push_back(p);
  if (parts.empty() || parts[0] != "charuco") bad(spec, "must start with 'charuco:'");
  if (parts.size() < 4 || parts.size() > 5) bad(spec, "expected 4 or 5 ':'-separated fields");
  BoardSpec b;
  const auto x = parts[1].find('x');
  if (x == std::string::npos) bad(spec, "squares '" + parts[1] + "' must be COLSxROWS");
  b.cols = parse_count(spec, parts[1].substr(0, x), "columns");
  b.rows = parse_count(spec, parts[1].substr(x + 1), "rows");
  b.square = parse_length(spec, parts[2], "square edge");
  b.marker = parse_length(spec, parts[3], "marker edge");
  if (!(b.marker < b.square)) bad(spec, "the marker edge must be smaller than the square edge");
  if (b.marker < 0.5 * b.square) bad(spec, "the marker edge must be at least half the square edge");
  if (parts.size() == 5) {
    b.dictionary = parts[4];
    try {
      (void)dictionary_id(b.dictionary);
    } catch (const InputError& e) {
      bad(spec, e.what());
    }
  }
  const int markers = b.cols * b.rows / 2;
  const auto dict = cv::aruco::getPredefinedDictionary(dictionary_id(b.dictionary));
  if (markers > dict->bytesList.rows) {
    bad(spec, std::to_string(markers) + " markers needed but " + b.dictionary + " has only " +
                  std::to_string(dict->bytesList.rows));
  }
  return b;
}

std::string BoardSpec::str() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "charuco:%dx%d:%.6g:%.6g:%s", cols, rows, square, marker, dictionary.c_str());
  return buf;
}

Board::Board(const BoardSpec& spec) : spec_(spec) {
  const auto dict = cv::aruco::getPredefinedDictionary(dictionary_id(spec.dictionary));
  board_ = cv::aruco::CharucoBoard::create(spec.cols, spec.rows, static_cast<float>(spec.square),
                                           static_cast<float>(spec.marker), dict);
  // Exact (double) corner positions: OpenCV stores floats.
  for (std::size_t i = 0; i < board_->chessboardCorners.size(); ++i) {
    const int cx = static_cast<int>(i) % (spec.cols - 1), cy = static_cast<int>(i) / (spec.cols - 1);
    corners_.emplace_back((cx + 1) * spec.square, (cy + 1) * spec.square, 0.0);
  }
  square_marker_.assign(static_cast<std::size_t>(spec.cols * spec.rows), -1);
  for (std::size_t m = 0; m < board_->objPoints.size(); ++m) {
    const auto& p = board_->objPoints[m];
    const double mx = 0.25 * (p[0].x + p[1].x + p[2].x + p[3].x);
    const double my = 0.25 * (p[0].y + p[1].y + p[2].y + p[3].y);
    const int col = static_cast<int>(std::floor(mx / spec.square));
    const int row = static_cast<int>(std::floor(my / spec.square));
    square_marker_[static_cast<std::size_t>(row * spec.cols + col)] = static_cast<int>(m);
    cv::Mat img, cells;
    cv::aruco::drawMarker(dict, board_->ids[m], dict->markerSize + 2, img, 1);
    cv::threshold(img, cells, 127, 1, cv::THRESH_BINARY);
    patterns_.push_back(cells);
  }
}

int Board::colour_at(double x, double y, int* region) const {
  const double sq = spec_.square;
  if (!(x >= 0 && y >= 0 && x < spec_.cols * sq && y < spec_.rows * sq)) {
    if (region) *region = -1;
    return -1;
  }
  const int col = std::min(spec_.cols - 1, static_cast<int>(x / sq));
  const int row = std::min(spec_.rows - 1, static_cast<int>(y / sq));
  const int square = row * spec_.cols + col;
  const int m = square_marker_[static_cast<std::size_t>(square)];
  if (m < 0) {
    if (region) *region = square * 1000;
    return 0;
  }
  // Marker cells from OpenCV's own marker corners: corner 0 is the pattern's top-left,
  // corner 1 its top-right, corner 3 its bottom-left.
  const auto& p = board_->objPoints[static_cast<std::size_t>(m)];
  const double ux = p[1].x - p[0].x, uy = p[1].y - p[0].y;
  const double vx = p[3].x - p[0].x, vy = p[3].y - p[0].y;
  const double dx = x - p[0].x, dy = y - p[0].y;
  const double s = (dx * ux + dy * uy) / (ux * ux + uy * uy);
  const double t = (dx * vx + dy * vy) / (vx * vx + vy * vy);
  const cv::Mat& cells = patterns_[static_cast<std::size_t>(m)];
  if (!(s >= 0 && s < 1 && t >= 0 && t < 1)) {
    if (region) *region = square * 1000 + 999;  // the white paper around the marker
    return 1;
  }
  const int c = std::min(cells.cols - 1, static_cast<int>(s * cells.cols));
  const int r = std::min(cells.rows - 1, static_cast<int>(t * cells.rows));
  if (region) *region = square * 1000 + 1 + r * cells.cols + c;
  return cells.at<std::uint8_t>(r, c);
}

std::vector<cv::Vec4d> Board::black_rects() const {
  std::vector<cv::Vec4d> out;
  const double sq = spec_.square;
  for (int row = 0; row < spec_.rows; ++row) {
    for (int col = 0; col < spec_.cols; ++col) {
      const int m = square_marker_[static_cast<std::size_t>(row * spec_.cols + col)];
      if (m < 0) {
        out.push_back({col * sq, row * sq, (col + 1) * sq, (row + 1) * sq});
        continue;
      }
      const auto& p = board_->objPoints[static_cast<std::size_t>(m)];
      const cv::Mat& cells = patterns_[static_cast<std::size_t>(m)];
      // The marker is axis-aligned in the board frame (OpenCV places it so); its pattern's
      // rows run from corner 0 towards corner 3.
      const double x0 = std::min({p[0].x, p[1].x, p[2].x, p[3].x});
      const double cell = spec_.marker / cells.cols;
      const double row_step = p[3].y > p[0].y ? cell : -cell;
      for (int r = 0; r < cells.rows; ++r) {
        int c = 0;
        while (c < cells.cols) {
          if (cells.at<std::uint8_t>(r, c) != 0) {
            ++c;
            continue;
          }
          int e = c;
          while (e < cells.cols && cells.at<std::uint8_t>(r, e) == 0) ++e;
          const double ya = p[0].y + r * row_step, yb = p[0].y + (r + 1) * row_step;
          out.push_back({x0 + c * cell, std::min(ya, yb), x0 + e * cell, std::max(ya, yb)});
          c = e;
        }
      }
    }
  }
  return out;
}

}  // namespace ips::calib
