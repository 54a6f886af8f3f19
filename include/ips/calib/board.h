// The ChArUco calibration board: one spec string names it everywhere (`ips board`,
// `ips calibrate`, `ips sim board-views`), and one geometry serves printing, rendering and
// detection so that they cannot disagree.
//
// Spec: charuco:COLSxROWS:SQUARE:MARKER[:DICT], e.g. charuco:7x5:0.04:0.03:DICT_5X5_100 —
// columns x rows chessboard squares, square and marker edge in metres, an OpenCV predefined
// dictionary (default DICT_5X5_100: never the robots' DICT_4X4_*, so a board never shows up
// as robots).
//
// Board frame (OpenCV 4.6 contrib's): origin at the printed board's top-left corner, x to the
// right along the columns, y DOWN the rows as printed, z into the sheet (away from a viewer
// who faces the print). The top-left square is black. Chessboard corner id i sits at
// ((i % (cols-1)) + 1, (i / (cols-1)) + 1) * square.
#pragma once

#include <string>
#include <vector>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/core.hpp>

namespace ips::calib {

inline constexpr const char* kDefaultBoardSpec = "charuco:7x5:0.04:0.03:DICT_5X5_100";
inline constexpr const char* kDefaultBoardDictionary = "DICT_5X5_100";

struct BoardSpec {
  int cols = 7;          ///< chessboard squares along x
  int rows = 5;          ///< chessboard squares along y
  double square = 0.04;  ///< square edge, metres
  double marker = 0.03;  ///< marker edge (outer black border), metres
  std::string dictionary = kDefaultBoardDictionary;

  /// Parses the spec string; throws ips::InputError naming the spec and what is wrong.
  static BoardSpec parse(const std::string& spec);
  std::string str() const;  ///< the canonical spec string (parse(str()) == *this)

  double width() const { return cols * square; }
  double height() const { return rows * square; }
  int corner_count() const { return (cols - 1) * (rows - 1); }
};

/// A board's geometry in the board frame (metres) and its OpenCV object.
class Board {
 public:
  explicit Board(const BoardSpec& spec);

  const BoardSpec& spec() const { return spec_; }
  const cv::Ptr<cv::aruco::CharucoBoard>& charuco() const { return board_; }
  /// Chessboard corner positions (z = 0), indexed by ChArUco corner id.
  const std::vector<cv::Point3d>& corners() const { return corners_; }

  /// What is printed at board point (x, y): 0 = black, 1 = white (paper inside the board
  /// rectangle); -1 = outside the board rectangle. Also returns a region id: two points with
  /// the same region id lie in one convex patch of uniform colour.
  int colour_at(double x, double y, int* region = nullptr) const;

  /// Black rectangles [x0, y0, x1, y1] in the board frame whose union is everything printed
  /// black (squares and marker cells; adjacent cells of one marker row are merged).
  std::vector<cv::Vec4d> black_rects() const;

 private:
  BoardSpec spec_;
  cv::Ptr<cv::aruco::CharucoBoard> board_;
  std::vector<cv::Point3d> corners_;
  std::vector<int> square_marker_;  ///< per square (row-major, y up): marker index or -1
  std::vector<cv::Mat> patterns_;   ///< per marker: (bits+2)^2 cells, 0 black, 1 white
};

/// The printable sheet (`ips board`): the board at exact physical size with a 15 mm white
/// margin, and below it the spec string and a 100 mm check bar (measure it after printing).
struct SheetLayout {
  double margin_mm = 15.0;
  double page_w_mm = 0, page_h_mm = 0;
  double board_x_mm = 0, board_y_mm = 0;  ///< page position of the board's top-left corner
  double bar_x_mm = 0, bar_y_mm = 0;      ///< top-left of the check bar
  double bar_len_mm = 100.0, bar_h_mm = 3.0;
  double text_y_mm = 0;  ///< baseline of the spec text
};
SheetLayout sheet_layout(const BoardSpec& spec);

/// The sheet as SVG, in millimetres (prints at 100 % at exact size).
std::string board_svg(const Board& board);
/// The sheet as an 8-bit greyscale raster at `dpi` dots per inch.
cv::Mat board_raster(const Board& board, double dpi);

}  // namespace ips::calib
