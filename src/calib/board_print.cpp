// The printable ChArUco sheet: vector (SVG, millimetres) and raster (any dpi) from the same
// black rectangles of the board geometry, so the print and what the detector expects agree.
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "ips/calib/board.h"

namespace ips::calib {

SheetLayout sheet_layout(const BoardSpec& spec) {
  SheetLayout l;
  const double bw = spec.width() * 1000.0, bh = spec.height() * 1000.0;
  l.board_x_mm = l.margin_mm;
  l.board_y_mm = l.margin_mm;
  l.text_y_mm = l.margin_mm + bh + 8.0;
  l.bar_x_mm = l.margin_mm;
  l.bar_y_mm = l.text_y_mm + 4.0;
  l.page_w_mm = std::max(bw, l.bar_len_mm + 25.0) + 2 * l.margin_mm;
  l.page_h_mm = l.bar_y_mm + l.bar_h_mm + l.margin_mm;
  return l;
}

namespace {
// Board frame (metres, y down the print) -> page (millimetres).
cv::Vec4d to_page(const cv::Vec4d& r, const SheetLayout& l) {
  return {l.board_x_mm + r[0] * 1000.0, l.board_y_mm + r[1] * 1000.0, l.board_x_mm + r[2] * 1000.0,
          l.board_y_mm + r[3] * 1000.0};
}
}  // namespace

std::string board_svg(const Board& board) {
  const BoardSpec& spec = board.spec();
  const SheetLayout l = sheet_layout(spec);
  std::string s;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                "<!-- ChArUco calibration board %s: print at 100 %% (no scaling), then check that "
                "the bar measures 100 mm. -->\n"
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.3fmm\" height=\"%.3fmm\" "
                "viewBox=\"0 0 %.3f %.3f\" shape-rendering=\"crispEdges\">\n"
                "<rect x=\"0\" y=\"0\" width=\"%.3f\" height=\"%.3f\" fill=\"#ffffff\"/>\n<g fill=\"#000000\">\n",
                spec.str().c_str(), l.page_w_mm, l.page_h_mm, l.page_w_mm, l.page_h_mm, l.page_w_mm, l.page_h_mm);
  s += buf;
  for (const auto& r : board.black_rects()) {
    const cv::Vec4d p = to_page(r, l);
    std::snprintf(buf, sizeof buf, "<rect x=\"%.4f\" y=\"%.4f\" width=\"%.4f\" height=\"%.4f\"/>\n", p[0], p[1],
                  p[2] - p[0], p[3] - p[1]);
    s += buf;
  }
  std::snprintf(buf, sizeof buf,
                "</g>\n<text x=\"%.3f\" y=\"%.3f\" font-family=\"monospace\" font-size=\"3.5\">%s  "
                "(square %.1f mm, marker %.1f mm)</text>\n"
                "<rect x=\"%.3f\" y=\"%.3f\" width=\"%.3f\" height=\"%.3f\" fill=\"#000000\"/>\n"
                "<text x=\"%.3f\" y=\"%.3f\" font-family=\"monospace\" font-size=\"3.5\">100 mm</text>\n"
                "</svg>\n",
                l.margin_mm, l.text_y_mm, spec.str().c_str(), spec.square * 1000, spec.marker * 1000, l.bar_x_mm,
                l.bar_y_mm, l.bar_len_mm, l.bar_h_mm, l.bar_x_mm + l.bar_len_mm + 3.0, l.bar_y_mm + l.bar_h_mm);
  s += buf;
  return s;
}

cv::Mat board_raster(const Board& board, double dpi) {
  const BoardSpec& spec = board.spec();
  const SheetLayout l = sheet_layout(spec);
  const double ppm = dpi / 25.4;  // pixels per millimetre
  auto px = [&](double mm) { return static_cast<int>(std::lround(mm * ppm)); };
  cv::Mat img(px(l.page_h_mm), px(l.page_w_mm), CV_8U, cv::Scalar(255));
  auto fill = [&](double x0, double y0, double x1, double y1) {
    // Pixel [i, i+1) is black when its centre lies inside: edges land within half a pixel.
    const cv::Rect r(cv::Point(px(x0), px(y0)), cv::Point(px(x1), px(y1)));
    img(r & cv::Rect(0, 0, img.cols, img.rows)).setTo(0);
  };
  for (const auto& r : board.black_rects()) {
    const cv::Vec4d p = to_page(r, l);
    fill(p[0], p[1], p[2], p[3]);
  }
  fill(l.bar_x_mm, l.bar_y_mm, l.bar_x_mm + l.bar_len_mm, l.bar_y_mm + l.bar_h_mm);
  const double scale = 3.5 * ppm / 22.0;  // ~3.5 mm high text (Hershey simplex is ~22 px at scale 1)
  const int thick = std::max(1, static_cast<int>(std::lround(0.3 * ppm)));
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s  (square %.1f mm, marker %.1f mm)", spec.str().c_str(), spec.square * 1000,
                spec.marker * 1000);
  cv::putText(img, buf, cv::Point(px(l.margin_mm), px(l.text_y_mm)), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0),
              thick, cv::LINE_AA);
  cv::putText(img, "100 mm", cv::Point(px(l.bar_x_mm + l.bar_len_mm + 3.0), px(l.bar_y_mm + l.bar_h_mm)),
              cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0), thick, cv::LINE_AA);
  return img;
}

}  // namespace ips::calib
