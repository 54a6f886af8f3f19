// `ips board`: the printable ChArUco calibration board (SVG at exact size, optional PNG).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/calib/board.h"
#include "ips/core/error.h"

namespace cmd_board {  // named, not anonymous: unique in a unity build

struct Args {
  std::string board = ips::calib::kDefaultBoardSpec;
  std::string out, png;
  double dpi = 300.0;
};

std::uint32_t crc32(const std::uint8_t* p, std::size_t n) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

// Stores the physical resolution (a pHYs chunk right after IHDR), so that image viewers and
// printers print the PNG at its true size. OpenCV's encoder writes none.
void add_png_resolution(std::vector<std::uint8_t>& png, double dpi) {
  constexpr std::size_t kAfterIhdr = 8 + 4 + 4 + 13 + 4;  // signature + IHDR chunk
  if (png.size() < kAfterIhdr) throw std::runtime_error("PNG encoding failed");
  const auto ppm = static_cast<std::uint32_t>(std::lround(dpi / 0.0254));  // pixels per metre
  std::vector<std::uint8_t> chunk{0, 0, 0, 9, 'p', 'H', 'Y', 's'};
  for (int axis = 0; axis < 2; ++axis)
    for (int b = 3; b >= 0; --b) chunk.push_back(static_cast<std::uint8_t>(ppm >> (8 * b)));
  chunk.push_back(1);  // unit: metre
  const std::uint32_t crc = crc32(chunk.data() + 4, chunk.size() - 4);
  for (int b = 3; b >= 0; --b) chunk.push_back(static_cast<std::uint8_t>(crc >> (8 * b)));
  png.insert(png.begin() + kAfterIhdr, chunk.begin(), chunk.end());
}

int run(const Args& a) {
  const ips::calib::Board board(ips::calib::BoardSpec::parse(a.board));
  if (!(a.dpi >= 50 && a.dpi <= 2400)) throw ips::InputError("--dpi must be 50..2400");
  const std::string svg = ips::calib::board_svg(board);
  std::vector<std::uint8_t> png;
  if (!a.png.empty()) {
    cv::imencode(".png", ips::calib::board_raster(board, a.dpi), png);
    add_png_resolution(png, a.dpi);
  }
  ips::cli::write_file_atomically(a.out, svg);
  if (!a.png.empty()) ips::cli::write_file_atomically(a.png, std::string(png.begin(), png.end()));
  const auto l = ips::calib::sheet_layout(board.spec());
  std::printf(
      "wrote %s (%.1f x %.1f mm sheet; board %s, %.0f x %.0f mm)%s\n", a.out.c_str(), l.page_w_mm, l.page_h_mm,
      board.spec().str().c_str(), board.spec().width() * 1000, board.spec().height() * 1000,
      a.png.empty() ? "" : (" and " + a.png + " at " + std::to_string(static_cast<int>(a.dpi)) + " dpi").c_str());
  std::printf("print at 100 %% (no 'fit to page') and check that the bar measures 100 mm\n");
  return 0;
}

std::function<int()> setup(CLI::App& sub) {
  auto a = std::make_shared<Args>();
  sub.add_option("--board", a->board, "Board spec charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT]")->capture_default_str();
  sub.add_option("--out", a->out, "SVG file to write (vector, exact size)")->required();
  sub.add_option("--png", a->png, "Also write a PNG raster");
  sub.add_option("--dpi", a->dpi, "PNG resolution, dots per inch")->capture_default_str();
  return [a] { return run(*a); };
}

IPS_REGISTER_COMMAND("board", "Write a printable ChArUco calibration board (SVG, optional PNG)", setup);

}  // namespace cmd_board
