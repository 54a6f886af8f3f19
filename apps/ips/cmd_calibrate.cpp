// `ips calibrate`: camera intrinsics from ChArUco board views, offline from a directory of
// images or live from a camera (any frame source: V4L2 device, or a configured camera).
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/calib/board.h"
#include "ips/calib/calibrate.h"
#include "ips/calib/charuco.h"
#include "ips/calib/live.h"
#include "ips/config/config.h"
#include "ips/config/source_factory.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace fs = std::filesystem;
using namespace ips::calib;

namespace cmd_calibrate {  // named, not anonymous: unique in a unity build

struct Args {
  std::string images, device, config, camera;
  std::string board = kDefaultBoardSpec;
  std::string model = "fisheye";
  std::string out, report, truth, save_views;
  bool json = false;
  bool thin_prism = false;
  int views = 30;
  double max_seconds = 600;
  double magnify = 50;
  int min_views = 6;
};

bool is_image(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".bmp" || e == ".tif" || e == ".tiff" || e == ".pgm" ||
         e == ".ppm";
}

std::vector<BoardObservation> observe_directory(const std::string& dir, const Board& board) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw ips::InputError("--images " + dir + ": not a directory");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && is_image(e.path())) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  if (files.empty()) throw ips::InputError("--images " + dir + ": no image files (.png .jpg ...)");
  std::vector<BoardObservation> out;
  for (const auto& f : files) {
    const cv::Mat gray = ips::cli::read_gray_image(f);  // names the file when unreadable
    BoardObservation o = detect_board(gray, board);
    o.name = f.filename().string();
    out.push_back(std::move(o));
  }
  return out;
}

// Live: frames from any source until enough views are kept; every kept view is saved.
std::vector<BoardObservation> observe_live(const Args& a, const Board& board, std::string& source_name) {
  ips::CameraConfig cam;
  if (!a.device.empty()) {
    cam.index = 0;
    cam.name = "calibrate";
    cam.source = ips::SourceKind::kV4l2;
    cam.v4l2.device = a.device;
  } else {
    // The camera's intrinsics file need not exist yet (this run writes it), nor the model file.
    const ips::DaemonConfig cfg = ips::load_config(a.config, ips::ConfigChecks{false, false});
    auto it = std::find_if(cfg.cameras.begin(), cfg.cameras.end(), [&](const auto& c) { return c.name == a.camera; });
    if (it == cfg.cameras.end()) {
      std::string names;
      for (const auto& c : cfg.cameras) names += (names.empty() ? "" : ", ") + c.name;
      throw ips::InputError(a.config + ": no camera named '" + a.camera + "' (cameras: " + names + ")");
    }
    cam = *it;
  }
  ips::SourceContext ctx;
  ctx.synthetic_epoch_mono_ns = ips::monotonic_ns();
  auto source = ips::make_source_factory(cam, ctx)();
  source_name = source->describe();
  const fs::path views_dir = a.save_views.empty() ? fs::path(fs::path(a.out).replace_extension("").string() + "_views")
                                                  : fs::path(a.save_views);
  try {
    source->open();
  } catch (const ips::SourceError& e) {
    throw ips::InputError(e.what());  // a wrong path or a busy device: nothing was written
  }
  std::fprintf(stderr,
               "live calibration from %s: hold the board in view, still, in every part of "
               "the image and at several tilts; kept views go to %s\n",
               source_name.c_str(), views_dir.string().c_str());
  std::unique_ptr<ViewSelector> selector;
  ips::Frame frame;
  const auto start = std::chrono::steady_clock::now();
  auto last_status = start;
  std::string last_reason;
  std::uint64_t frames = 0;
  cv::Size first_size;
  while (true) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > a.max_seconds) {
      std::fprintf(stderr, "stopping after --max-seconds %.0f\n", a.max_seconds);
      break;
    }
    const auto st = source->read(frame, std::chrono::milliseconds(500));
    if (st == ips::FrameSource::ReadStatus::kEnd) break;
    if (st != ips::FrameSource::ReadStatus::kFrame) continue;
    ++frames;
    if (!selector) {
      selector = std::make_unique<ViewSelector>(board, frame.gray.size(), LiveOptions{a.views});
      first_size = frame.gray.size();
      fs::create_directories(views_dir);
    }
    if (frame.gray.size() != first_size) {
      throw ips::SourceError(source_name + ": the frame size changed during calibration");
    }
    BoardObservation obs = detect_board(frame.gray, board);
    char name[32];
    std::snprintf(name, sizeof name, "view_%03zu.png", selector->kept().size());
    obs.name = name;
    const auto d = selector->offer(frame.gray, obs);
    last_reason = d.reason;
    if (d.kept) {
      cv::imwrite((views_dir / name).string(), frame.gray);
      std::fprintf(stderr, "%s: %s\n%s", name, d.reason.c_str(), selector->progress().c_str());
      if (selector->done()) break;
    } else if (std::chrono::steady_clock::now() - last_status > std::chrono::seconds(2)) {
      last_status = std::chrono::steady_clock::now();
      std::fprintf(stderr, "  frame %llu: %s (views kept %zu/%d)\n", static_cast<unsigned long long>(frames),
                   last_reason.c_str(), selector->kept().size(), a.views);
    }
  }
  source->close();
  if (!selector) throw ips::InputError(source_name + ": no frames arrived");
  return selector->kept();
}

int run(const Args& a) {
  const int modes = (!a.images.empty()) + (!a.device.empty()) + (!a.config.empty());
  if (modes != 1) throw ips::InputError("give exactly one of --images DIR, --device PATH, --config FILE");
  if (!a.config.empty() && a.camera.empty()) throw ips::InputError("--config needs --camera NAME");
  if (a.model != "fisheye" && a.model != "pinhole")
    throw ips::InputError("--model must be fisheye or pinhole, got '" + a.model + "'");
  if (a.views < 3 || a.views > 500) throw ips::InputError("--views must be 3..500");
  const BoardSpec spec = BoardSpec::parse(a.board);
  const Board board(spec);
  std::optional<ips::CameraModel> truth;
  if (!a.truth.empty()) truth = ips::CameraModel::load(a.truth);

  std::string source = a.images;
  const std::vector<BoardObservation> obs =
      a.images.empty() ? observe_live(a, board, source) : observe_directory(a.images, board);
  CalibrationOptions opt;
  opt.kind = a.model == "fisheye" ? ips::CameraModel::Kind::kFisheye : ips::CameraModel::Kind::kPinhole;
  opt.min_views = a.min_views;
  if (a.thin_prism && opt.kind != ips::CameraModel::Kind::kPinhole)
    throw ips::InputError("--thin-prism needs --model pinhole");
  opt.thin_prism = a.thin_prism;
  const CalibrationResult r = calibrate(obs, board, opt);

  // Human-readable report (stderr when --json takes stdout).
  FILE* out = a.json ? stderr : stdout;
  std::fprintf(out, "%s calibration from %zu image(s), board %s\n", a.model.c_str(), obs.size(), spec.str().c_str());
  for (const auto& v : r.views) {
    std::fprintf(out, "  %-28s %3d corners  ", v.name.c_str(), v.corners);
    if (!v.residual.empty()) std::fprintf(out, "RMS %6.3f px  ", v.rms);
    if (v.corners_dropped > 0) std::fprintf(out, "(%d outlier corner(s) removed) ", v.corners_dropped);
    std::fprintf(out, "%s\n", v.used ? "" : ("NOT USED: " + v.why).c_str());
  }
  std::fprintf(out, "RMS reprojection error %.3f px over %d views\n", r.rms, r.used_views);
  std::fprintf(out, "coverage %.0f%% of a %dx%d grid; largest field angle covered %.1f deg\n", 100 * r.coverage,
               r.grid.width, r.grid.height, r.max_field_deg);
  if (r.turn_back_deg) {
    std::fprintf(out,
                 "the fitted fisheye polynomial turns back at %.1f deg (image radius %.0f px): pixels "
                 "beyond have no ray and are ignored by ipsd%s\n",
                 *r.turn_back_deg, r.turn_back_radius_px,
                 *r.turn_back_deg < r.max_field_deg ? " -- WARNING: inside the covered field" : "");
  }
  if (r.corners_without_ray > 0)
    std::fprintf(out, "WARNING: %d used corners have no ray in the fitted model\n", r.corners_without_ray);
  if (truth) {
    std::vector<cv::Point2d> pts;
    for (const auto& v : r.views)
      if (v.used) pts.insert(pts.end(), v.px.begin(), v.px.end());
    const auto d = compare_models(*truth, r.model, pts);
    char plain_text[160];
    try {
      const auto plain = compare_models(*truth, calibrate_opencv_plain(obs, board, opt.kind, 8, opt.thin_prism), pts);
      std::snprintf(plain_text, sizeof plain_text, "max %.3f px, RMS %.3f px", plain.max_px, plain.rms_px);
    } catch (const cv::Exception& e) {
      std::snprintf(plain_text, sizeof plain_text, "fails: %s", e.err.c_str());
    }
    std::fprintf(out,
                 "vs %s over the covered field (%d px): max %.3f px at (%.0f, %.0f), RMS %.3f px "
                 "(plain OpenCV on the same corners: %s)\n",
                 a.truth.c_str(), d.pixels, d.max_px, d.worst.x, d.worst.y, d.rms_px, plain_text);
  }

  // Everything checked: write.
  std::vector<std::uint8_t> png;
  if (!a.report.empty()) cv::imencode(".png", draw_report(r, spec, a.magnify), png);
  ips::cli::write_file_atomically(a.out, intrinsics_yaml(r, spec, source));
  if (!a.report.empty()) ips::cli::write_file_atomically(a.report, std::string(png.begin(), png.end()));
  if (a.json) std::fputs(result_json(r, spec).c_str(), stdout);
  std::fprintf(out, "wrote %s%s\n", a.out.c_str(), a.report.empty() ? "" : (" and " + a.report).c_str());
  return 0;
}

std::function<int()> setup(CLI::App& sub) {
  auto a = std::make_shared<Args>();
  sub.add_option("--images", a->images, "Offline: directory of board images");
  sub.add_option("--device", a->device, "Live: V4L2 device, e.g. /dev/v4l/by-id/...");
  sub.add_option("--config", a->config, "Live: ipsd config whose camera --camera to use");
  sub.add_option("--camera", a->camera, "Live: camera name in --config");
  sub.add_option("--board", a->board, "Board spec charuco:COLSxROWS:SQUARE_M:MARKER_M[:DICT]")->capture_default_str();
  sub.add_option("--model", a->model, "fisheye | pinhole (rational model)")->capture_default_str();
  sub.add_option("--out", a->out, "Intrinsics YAML to write")->required();
  sub.add_option("--report", a->report, "Report PNG: coverage and magnified residuals");
  sub.add_flag("--json", a->json, "Print the numbers as JSON on stdout");
  sub.add_flag("--thin-prism", a->thin_prism, "Pinhole: add the thin-prism terms (12 coefficients)");
  sub.add_option("--truth", a->truth, "True intrinsics (simulation): print how far the result projects from them");
  sub.add_option("--views", a->views, "Live: views to keep")->capture_default_str();
  sub.add_option("--save-views", a->save_views, "Live: directory for the kept views (default: OUT_views)");
  sub.add_option("--max-seconds", a->max_seconds, "Live: give up collecting after this long")->capture_default_str();
  sub.add_option("--min-views", a->min_views, "Fewest usable views to calibrate from")->capture_default_str();
  sub.add_option("--magnify", a->magnify, "Report: residual vector magnification")->capture_default_str();
  return [a] { return run(*a); };
}

IPS_REGISTER_COMMAND("calibrate", "Camera intrinsics from ChArUco board views (offline or live)", setup);

}  // namespace cmd_calibrate
