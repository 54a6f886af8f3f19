// `ips board`: the printable ChArUco calibration board (SVG at exact size, optional PNG).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/calib/board.h"
#include "ips/error.h"

namespace {

struct Args {
  std::string board = ips::calib::kDefaultBoardSpec;
  std::string out, png;
  double dpi = 300.0;
};

int run(const Args& a) {
  const ips::calib::Board board(ips::calib::BoardSpec::parse(a.board));
  if (!(a.dpi >= 50 && a.dpi <= 2400)) throw ips::InputError("--dpi must be 50..2400");
  const std::string svg = ips::calib::board_svg(board);
  std::vector<std::uint8_t> png;
  if (!a.png.empty()) {
    // PNG with its physical resolution stored (pHYs), so viewers and printers know the size.
    cv::imencode(".png", ips::calib::board_raster(board, a.dpi), png);
  }
  ips::cli::write_file_atomically(a.out, svg);
  if (!a.png.empty()) ips::cli::write_file_atomically(a.png, std::string(png.begin(), png.end()));
  const auto l = ips::calib::sheet_layout(board.spec());
  std::printf("wrote %s (%.1f x %.1f mm sheet; board %s, %.0f x %.0f mm)%s\n", a.out.c_str(),
              l.page_w_mm, l.page_h_mm, board.spec().str().c_str(), board.spec().width() * 1000,
              board.spec().height() * 1000,
              a.png.empty() ? "" : (" and " + a.png + " at " + std::to_string(static_cast<int>(a.dpi)) + " dpi").c_str());
  std::printf("print at 100 %% (no 'fit to page') and check that the bar measures 100 mm\n");
  return 0;
}

std::function<int()> setup(CLI::App& sub) {
  auto a = std::make_shared<Args>();
  sub.add_option("--board", a->board, "Board spec charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT]")
      ->capture_default_str();
  sub.add_option("--out", a->out, "SVG file to write (vector, exact size)")->required();
  sub.add_option("--png", a->png, "Also write a PNG raster");
  sub.add_option("--dpi", a->dpi, "PNG resolution, dots per inch")->capture_default_str();
  return [a] { return run(*a); };
}

IPS_REGISTER_COMMAND("board", "Write a printable ChArUco calibration board (SVG, optional PNG)", setup);

}  // namespace
