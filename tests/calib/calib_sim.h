// Shared by the calibration tests: simulated board views of one lens of
// config/scenes/calib_lenses.yaml, through JPEG, detected like `ips calibrate` does.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ips/calib/board.h"
#include "ips/calib/charuco.h"
#include "ips/capture/jpeg_decoder.h"
#include "ips/sim/board_renderer.h"
#include "ips/sim/scene.h"

namespace calib_test {

struct LensViews {
  std::unique_ptr<ips::sim::Scene> scene;
  std::unique_ptr<ips::sim::CameraRenderer> camera;
  std::unique_ptr<ips::calib::Board> board;
  std::unique_ptr<ips::sim::BoardRenderer> renderer;
  std::vector<ips::sim::BoardView> views;
  std::vector<cv::Mat> images;  ///< decoded JPEG frames
  std::vector<ips::calib::BoardObservation> observations;
  const ips::CameraModel& truth() const { return camera->camera().model; }
};

inline LensViews make_views(const std::string& lens, int count, unsigned seed = 1) {
  LensViews v;
  v.scene = std::make_unique<ips::sim::Scene>(
      ips::sim::Scene::load(std::string(IPS_CONFIG_DIR) + "/scenes/calib_lenses.yaml"));
  v.camera = std::make_unique<ips::sim::CameraRenderer>(*v.scene, v.scene->camera_index(lens));
  v.board = std::make_unique<ips::calib::Board>(ips::calib::BoardSpec::parse(ips::calib::kDefaultBoardSpec));
  v.renderer = std::make_unique<ips::sim::BoardRenderer>(*v.camera, *v.board, 0.01);
  ips::sim::BoardViewOptions o;
  o.views = count;
  o.seed = seed;
  v.views = ips::sim::generate_board_views(*v.renderer, o);
  ips::JpegDecoder decoder;
  cv::Mat gray;
  for (std::size_t k = 0; k < v.views.size(); ++k) {
    v.renderer->render(v.views[k].pose, v.views[k].look, gray, k);
    cv::Mat decoded;
    if (!decoder.decode_gray(ips::sim::encode_jpeg(gray, v.scene->render.jpeg_quality, true), decoded))
      throw std::runtime_error("JPEG round trip failed");
    auto obs = ips::calib::detect_board(decoded, *v.board);
    obs.name = "view " + std::to_string(k);
    v.observations.push_back(std::move(obs));
    v.images.push_back(decoded);
  }
  return v;
}

}  // namespace calib_test
