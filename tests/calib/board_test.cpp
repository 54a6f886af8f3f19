// The board spec, its geometry against OpenCV's own board, and the printed sheet detected
// by OpenCV's ChArUco functions at the stated scale.
#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/aruco.hpp>
#include <opencv2/aruco/charuco.hpp>

#include "ips/calib/board.h"
#include "ips/core/error.h"

using ips::calib::Board;
using ips::calib::BoardSpec;

TEST(BoardSpec, ParsesTheDefaultAndRoundTrips) {
  const BoardSpec b = BoardSpec::parse("charuco:7x5:0.04:0.03:DICT_5X5_100");
  EXPECT_EQ(b.cols, 7);
  EXPECT_EQ(b.rows, 5);
  EXPECT_DOUBLE_EQ(b.square, 0.04);
  EXPECT_DOUBLE_EQ(b.marker, 0.03);
  EXPECT_EQ(b.dictionary, "DICT_5X5_100");
  EXPECT_EQ(BoardSpec::parse(b.str()).str(), b.str());
  // The dictionary is optional and never the robots' 4x4 by default.
  EXPECT_EQ(BoardSpec::parse("charuco:9x6:0.05:0.038").dictionary, "DICT_5X5_100");
  EXPECT_EQ(b.corner_count(), 24);
}

TEST(BoardSpec, BadSpecsNameWhatIsWrong) {
  const std::pair<const char*, const char*> cases[] = {
      {"chess:7x5:0.04:0.03", "must start with 'charuco:'"},
      {"charuco:7x5:0.04", "4 or 5"},
      {"charuco:7by5:0.04:0.03", "COLSxROWS"},
      {"charuco:7x2:0.04:0.03", "rows must be 3..40"},
      {"charuco:7x5:abc:0.03", "square edge 'abc' is not a number"},
      {"charuco:7x5:0.04:0.05", "smaller than the square"},
      {"charuco:7x5:0.04:-0.03", "marker edge must be in (0, 2]"},
      {"charuco:7x5:0.04:0.03:DICT_9X9_1", "unknown ArUco dictionary"},
      {"charuco:20x20:0.04:0.03:DICT_5X5_50", "200 markers needed"},
      {"charuco:7x5:0.04m:0.03", "is not a number"},
  };
  for (const auto& [spec, what] : cases) {
    try {
      (void)BoardSpec::parse(spec);
      ADD_FAILURE() << spec << " was accepted";
    } catch (const ips::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << spec << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(spec), std::string::npos) << e.what();
    }
  }
}

TEST(Board, GeometryAgreesWithOpenCVsBoard) {
  const Board board(BoardSpec::parse("charuco:7x5:0.04:0.03:DICT_5X5_100"));
  const auto& cb = *board.charuco();
  ASSERT_EQ(board.corners().size(), cb.chessboardCorners.size());
  for (std::size_t i = 0; i < cb.chessboardCorners.size(); ++i) {
    EXPECT_NEAR(board.corners()[i].x, cb.chessboardCorners[i].x, 1e-6);
    EXPECT_NEAR(board.corners()[i].y, cb.chessboardCorners[i].y, 1e-6);
  }
  // colour_at and black_rects describe the same print.
  const auto rects = board.black_rects();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(0, 0.28), uy(0, 0.20);
  int black = 0;
  for (int k = 0; k < 20000; ++k) {
    const double x = ux(rng), y = uy(rng);
    bool in_rect = false;
    for (const auto& r : rects) in_rect = in_rect || (x >= r[0] && x < r[2] && y >= r[1] && y < r[3]);
    const int c = board.colour_at(x, y);
    ASSERT_NE(c, -1);
    EXPECT_EQ(c == 0, in_rect) << x << " " << y;
    black += c == 0;
  }
  // Half the squares are black plus the markers' black cells: well over half of the area.
  EXPECT_GT(black, 10000);
  EXPECT_EQ(board.colour_at(-0.001, 0.1), -1);
}

TEST(Board, PrintedRasterIsDetectedAtTheStatedScale) {
  const Board board(BoardSpec::parse("charuco:7x5:0.04:0.03:DICT_5X5_100"));
  const double dpi = 150;
  const cv::Mat img = ips::calib::board_raster(board, dpi);
  const double ppm = dpi / 25.4;
  const auto l = ips::calib::sheet_layout(board.spec());
  EXPECT_EQ(img.cols, static_cast<int>(std::lround(l.page_w_mm * ppm)));

  std::vector<std::vector<cv::Point2f>> mc;
  std::vector<int> mids;
  cv::aruco::detectMarkers(img, board.charuco()->dictionary, mc, mids);
  EXPECT_EQ(mids.size(), board.charuco()->ids.size());
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(mc, mids, img, board.charuco(), corners, ids);
  ASSERT_EQ(static_cast<int>(ids.size()), board.spec().corner_count());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    // Where the sheet puts corner id: board frame y down the print, 15 mm margin.
    const auto& c = board.corners()[static_cast<std::size_t>(ids[i])];
    const double x = (l.board_x_mm + c.x * 1000) * ppm;
    const double y = (l.board_y_mm + c.y * 1000) * ppm;
    // Edges are rounded to whole pixels (0.17 mm at 150 dpi) and pixel centres sit at
    // integer coordinates: within a pixel.
    EXPECT_NEAR(corners[i].x, x - 0.5, 1.0) << "corner " << ids[i];
    EXPECT_NEAR(corners[i].y, y - 0.5, 1.0) << "corner " << ids[i];
  }
  // The scale: corners 0 and 5 are 5 squares apart along x, 0 and 18 3 squares along y.
  std::map<int, cv::Point2f> by_id;
  for (std::size_t i = 0; i < ids.size(); ++i) by_id[ids[i]] = corners[i];
  EXPECT_NEAR(by_id[5].x - by_id[0].x, 5 * 40 * ppm, 1.0);
  EXPECT_NEAR(by_id[18].y - by_id[0].y, 3 * 40 * ppm, 1.0);
  // The check bar: one black run of 100 mm across its middle row.
  const int row = static_cast<int>((l.bar_y_mm + 0.5 * l.bar_h_mm) * ppm);
  int run = 0, best = 0;
  for (int x = 0; x < img.cols; ++x) {
    run = img.at<std::uint8_t>(row, x) < 128 ? run + 1 : 0;
    best = std::max(best, run);
  }
  EXPECT_NEAR(best, 100 * ppm, 1.0);
}

TEST(Board, SvgHasExactPhysicalSize) {
  const Board board(BoardSpec::parse("charuco:7x5:0.04:0.03:DICT_5X5_100"));
  const std::string svg = ips::calib::board_svg(board);
  const auto l = ips::calib::sheet_layout(board.spec());
  char size[80];
  std::snprintf(size, sizeof size, "width=\"%.3fmm\" height=\"%.3fmm\"", l.page_w_mm, l.page_h_mm);
  EXPECT_NE(svg.find(size), std::string::npos);
  EXPECT_NE(svg.find("width=\"100.000\" height=\"3.000\""), std::string::npos);  // check bar
  EXPECT_NE(svg.find("charuco:7x5:0.04:0.03:DICT_5X5_100"), std::string::npos);
  // One rect per black region (squares, marker cell runs), the white page and the bar.
  std::size_t n = 0;
  for (std::size_t p = svg.find("<rect"); p != std::string::npos; p = svg.find("<rect", p + 1)) ++n;
  EXPECT_EQ(n, board.black_rects().size() + 2);
}
