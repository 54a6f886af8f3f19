// `ips sim board-views`: the ChArUco calibration board at many poses in front of one scene
// camera, rendered through that camera's own model, with the exact truth (poses, corner
// pixels, the true intrinsics) to check `ips calibrate` against.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/calib/board.h"
#include "ips/calib/calibrate.h"
#include "ips/core/error.h"
#include "ips/sim/board_renderer.h"
#include "ips/sim/scene.h"

namespace fs = std::filesystem;

namespace cmd_sim_board_views {  // named, not anonymous: unique in a unity build

struct Args {
  std::string scene, camera, out;
  std::string board = ips::calib::kDefaultBoardSpec;
  int views = 30;
  unsigned seed = 1;
  double max_blur = 0.6;
  double tilt_max = 50.0;
  double paper = 0.01;
};

int run(const Args& a) {
  if (a.views < 1 || a.views > 1000) throw ips::InputError("--views must be 1..1000");
  if (!(a.max_blur >= 0 && a.max_blur <= 5)) throw ips::InputError("--max-blur must be 0..5 px");
  if (!(a.tilt_max >= 10 && a.tilt_max <= 70)) throw ips::InputError("--max-tilt must be 10..70 deg");
  if (!(a.paper >= 0 && a.paper <= 0.2)) throw ips::InputError("--paper-margin must be 0..0.2 m");
  const auto spec = ips::calib::BoardSpec::parse(a.board);
  const ips::calib::Board board(spec);
  const auto scene = ips::sim::Scene::load(a.scene);
  const std::size_t cam = scene.camera_index(a.camera);
  const ips::sim::CameraRenderer camera(scene, cam);
  const ips::sim::BoardRenderer renderer(camera, board, a.paper);
  ips::sim::BoardViewOptions opt;
  opt.views = a.views;
  opt.seed = a.seed;
  opt.max_blur = a.max_blur;
  opt.tilt_max_deg = a.tilt_max;
  const auto views = ips::sim::generate_board_views(renderer, opt);
  if (views.size() < static_cast<std::size_t>(a.views)) {
    throw std::runtime_error("could place only " + std::to_string(views.size()) + " of " + std::to_string(a.views) +
                             " board views in camera " + a.camera);
  }
  fs::create_directories(a.out);
  const auto& model = camera.camera().model;
  nlohmann::json truth{{"scene", a.scene},
                       {"camera", a.camera},
                       {"board", spec.str()},
                       {"intrinsics", "true_intrinsics.yaml"},
                       {"noise_sigma", scene.render.noise_sigma},
                       {"jpeg_quality", scene.render.jpeg_quality},
                       {"views", nlohmann::json::array()}};
  cv::Mat gray;
  for (std::size_t k = 0; k < views.size(); ++k) {
    const auto& v = views[k];
    renderer.render(v.pose, v.look, gray, k);
    char stem[32];
    std::snprintf(stem, sizeof stem, "view_%03zu", k);
    std::string file = stem;
    std::string bytes;
    if (scene.render.jpeg_quality > 0) {
      const auto jpeg = ips::sim::encode_jpeg(gray, scene.render.jpeg_quality, true);
      bytes.assign(jpeg.begin(), jpeg.end());
      file += ".jpg";
    } else {
      std::vector<std::uint8_t> png;
      cv::imencode(".png", gray, png);
      bytes.assign(png.begin(), png.end());
      file += ".png";
    }
    ips::cli::write_file_atomically(fs::path(a.out) / file, bytes);
    cv::Matx33d R;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R(i, j) = v.pose.R(i, j);
    cv::Vec3d rvec;
    cv::Rodrigues(R, rvec);
    nlohmann::json corners = nlohmann::json::array();
    for (std::size_t i = 0; i < v.truth.corners_px.size(); ++i) {
      if (v.truth.visible[i]) corners.push_back({i, v.truth.corners_px[i].x, v.truth.corners_px[i].y});
    }
    truth["views"].push_back({{"image", file},
                              {"rvec", {rvec[0], rvec[1], rvec[2]}},
                              {"tvec", {v.pose.t.x(), v.pose.t.y(), v.pose.t.z()}},
                              {"blur_sigma_px", v.look.blur_sigma},
                              {"gradient", v.look.gradient},
                              {"corners", corners}});
  }
  ips::cli::write_file_atomically(fs::path(a.out) / "true_intrinsics.yaml", ips::calib::model_yaml(model));
  ips::cli::write_file_atomically(fs::path(a.out) / "truth.json", truth.dump(1) + "\n");
  std::printf("wrote %zu board views of camera %s (%s) to %s\n", views.size(), a.camera.c_str(), spec.str().c_str(),
              a.out.c_str());
  return 0;
}

std::function<int()> setup(CLI::App& sub) {
  auto a = std::make_shared<Args>();
  sub.add_option("--scene", a->scene, "Scene YAML file")->required();
  sub.add_option("--camera", a->camera, "Camera of the scene")->required();
  sub.add_option("--out", a->out, "Output directory (created): view_NNN.jpg, truth.json, true_intrinsics.yaml")
      ->required();
  sub.add_option("--views", a->views, "Number of views")->capture_default_str();
  sub.add_option("--board", a->board, "Board spec charuco:COLSxROWS:SQUARE:MARKER[:DICT]")->capture_default_str();
  sub.add_option("--seed", a->seed, "Random seed of the poses")->capture_default_str();
  sub.add_option("--max-blur", a->max_blur, "Defocus sigma drawn from [0, this], pixels")->capture_default_str();
  sub.add_option("--max-tilt", a->tilt_max, "Largest board tilt, degrees")->capture_default_str();
  sub.add_option("--paper-margin", a->paper, "White paper around the board, metres")->capture_default_str();
  return [a] { return run(*a); };
}

IPS_REGISTER_SIM_COMMAND("board-views", "Render the ChArUco board at many poses in front of a scene camera, with truth",
                         setup);

}  // namespace cmd_sim_board_views
