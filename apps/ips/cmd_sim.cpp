// `ips sim render` and `ips sim collect`: frames with exact ground truth, and the published
// calibration procedure reproduced in simulation.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/capture/jpeg_decoder.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"

namespace fs = std::filesystem;

namespace cmd_sim {  // named, not anonymous: unique in a unity build

using ips::sim::CameraRenderer;
using ips::sim::Scene;

struct RenderArgs {
  std::string scene;
  std::string out;
  int frames = 1;
  double fps = 30.0;
  std::vector<std::string> cameras;
  int restart_rows = -1;  // -1: the scene's render.jpeg_restart_rows
};

struct CollectArgs {
  std::string scene;
  std::string out;
  int points = 40;
  double tape_noise = 0.005;
  double max_height = 0.20;
  double marker_length = 0.20;
  unsigned seed = 1;
  std::vector<std::string> cameras;
};

std::vector<std::size_t> selected_cameras(const Scene& scene, const std::vector<std::string>& names) {
  std::vector<std::size_t> out;
  if (names.empty()) {
    for (std::size_t i = 0; i < scene.cameras.size(); ++i) out.push_back(i);
  } else {
    for (const auto& n : names) out.push_back(scene.camera_index(n));
  }
  return out;
}

nlohmann::json truth_json(const ips::sim::MarkerTruth& t) {
  nlohmann::json corners = nlohmann::json::array();
  for (const auto& c : t.corners_px) corners.push_back({c.x, c.y});
  nlohmann::json j{{"visible", t.visible},
                   {"corners", corners},
                   {"centre_cam", {t.centre_cam.x(), t.centre_cam.y(), t.centre_cam.z()}}};
  if (t.visible) {
    j["xc"] = t.formula.p_cam.x();
    j["yc"] = t.formula.p_cam.y();
    j["zc"] = t.formula.p_cam.z();
    j["yaw"] = t.formula.yaw;
    j["area"] = t.formula.area_px;
  }
  return j;
}

std::string encode_frame(const cv::Mat& gray, int quality, int restart_rows, std::string& extension) {
  if (quality > 0) {
    extension = ".jpg";
    const auto bytes = ips::sim::encode_jpeg(gray, quality, true, restart_rows);
    return {bytes.begin(), bytes.end()};
  }
  extension = ".png";
  std::vector<std::uint8_t> png;
  cv::imencode(".png", gray, png);
  return {png.begin(), png.end()};
}

int run_render(const RenderArgs& a) {
  if (a.frames < 1) throw ips::InputError("--frames must be >= 1");
  if (!(a.fps > 0)) throw ips::InputError("--fps must be > 0");
  Scene scene = Scene::load(a.scene);
  if (a.restart_rows > 255) throw ips::InputError("--jpeg-restart-rows must be 0..255");
  if (a.restart_rows >= 0) scene.render.jpeg_restart_rows = a.restart_rows;
  const auto cams = selected_cameras(scene, a.cameras);
  fs::create_directories(a.out);
  std::vector<std::unique_ptr<CameraRenderer>> renderers;
  for (std::size_t c : cams) renderers.push_back(std::make_unique<CameraRenderer>(scene, c));
  cv::Mat gray;
  for (int k = 0; k < a.frames; ++k) {
    const double t = k / a.fps;
    char stem[32];
    std::snprintf(stem, sizeof stem, "%06d", k);
    nlohmann::json frame{{"frame", k}, {"t", t}, {"images", nlohmann::json::object()}};
    nlohmann::json markers = nlohmann::json::array();
    for (std::size_t i = 0; i < scene.markers.size(); ++i) {
      const auto p = scene.marker_pose_at(i, t);
      markers.push_back({{"id", scene.markers[i].id},
                         {"length", scene.markers[i].length},
                         {"world", {{"x", p.x}, {"y", p.y}, {"z", p.z}, {"yaw", p.yaw}}},
                         {"cameras", nlohmann::json::object()}});
    }
    for (const auto& r : renderers) {
      const std::string& name = r->camera().name;
      r->render(t, gray, static_cast<std::uint64_t>(k));
      std::string ext;
      const std::string bytes = encode_frame(gray, scene.render.jpeg_quality, scene.render.jpeg_restart_rows, ext);
      const std::string file = name + "_" + stem + ext;
      ips::cli::write_file_atomically(fs::path(a.out) / file, bytes);
      frame["images"][name] = file;
      const auto truth = r->truth(t);
      for (std::size_t i = 0; i < truth.size(); ++i) markers[i]["cameras"][name] = truth_json(truth[i]);
    }
    frame["markers"] = markers;
    // Bodies (docs/bodies.md): each body's exact pose; its markers are in "markers" with "body".
    if (!scene.bodies.empty()) {
      nlohmann::json bodies = nlohmann::json::array();
      for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
        const ips::BodyPose bp = scene.body_pose_at(b, t);
        bodies.push_back({{"name", scene.bodies[b].def.name},
                          {"x", bp.position.x()},
                          {"y", bp.position.y()},
                          {"z", bp.position.z()},
                          {"yaw", bp.yaw},
                          {"q", {bp.q.w(), bp.q.x(), bp.q.y(), bp.q.z()}}});
      }
      for (std::size_t i = 0; i < scene.markers.size(); ++i)
        if (scene.markers[i].body >= 0)
          frame["markers"][i]["body"] = scene.bodies[static_cast<std::size_t>(scene.markers[i].body)].def.name;
      frame["bodies"] = bodies;
    }
    ips::cli::write_file_atomically(fs::path(a.out) / (std::string("truth_") + stem + ".json"), frame.dump() + "\n");
  }
  std::printf("wrote %d frame(s) x %zu camera(s) to %s\n", a.frames, cams.size(), a.out.c_str());
  return 0;
}

int run_collect(const CollectArgs& a) {
  if (a.points < 1) throw ips::InputError("--points must be >= 1");
  if (!(a.tape_noise >= 0 && a.tape_noise < 0.5)) throw ips::InputError("--tape-noise must be in [0, 0.5) m");
  if (!(a.max_height >= 0 && a.max_height < 1.5)) throw ips::InputError("--max-height must be in [0, 1.5) m");
  if (!(a.marker_length > 0.01)) throw ips::InputError("--marker-length must be > 0.01 m");
  const Scene scene = Scene::load(a.scene);
  const auto cams = selected_cameras(scene, a.cameras);
  std::mt19937_64 rng(a.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> tape(0.0, a.tape_noise);
  ips::DetectorOptions options;
  options.dictionary = scene.dictionary;
  ips::Detector detector(options);
  ips::JpegDecoder decoder;
  std::ostringstream csv;
  csv.precision(9);
  csv << "camera,xc,yc,zc,xw,yw,zw\n";
  cv::Mat gray, decoded;
  std::uint64_t frame = 0;
  for (std::size_t c : cams) {
    const CameraRenderer r(scene, c);
    const std::string& name = r.camera().name;
    int got = 0, missed = 0;
    while (got < a.points) {
      if (missed > 20 * a.points + 100) {
        throw std::runtime_error("camera " + name + ": the marker was not detected in " + std::to_string(missed) +
                                 " placements; check the scene");
      }
      // A random place on the floor, a random height and heading, as a person would put it.
      ips::sim::SceneMarker m;
      m.id = 0;
      m.length = a.marker_length;
      const ips::sim::MarkerPose pose{0.1 + u(rng) * (scene.floor.size_x - 0.2),
                                      0.1 + u(rng) * (scene.floor.size_y - 0.2), u(rng) * a.max_height,
                                      u(rng) * 2 * M_PI};
      if (!r.truth_of(m, pose).visible) continue;  // not in this camera's view
      r.render_markers({{m, {pose}}}, gray, frame++);
      const cv::Mat* image = &gray;
      if (scene.render.jpeg_quality > 0) {
        if (!decoder.decode_gray(
                ips::sim::encode_jpeg(gray, scene.render.jpeg_quality, true, scene.render.jpeg_restart_rows),
                decoded)) {
          throw std::runtime_error("JPEG round trip failed: " + decoder.error());
        }
        image = &decoded;
      }
      const auto found = detector.detect(*image, &r.camera().model);
      const ips::MarkerDetection* hit = nullptr;
      for (const auto& d : found) hit = d.id == m.id ? &d : hit;
      if (hit == nullptr) {
        ++missed;
        continue;
      }
      const auto o = ips::locate_marker(*hit, r.camera().model, m.length);
      if (!std::isfinite(o.p_cam.z())) {
        ++missed;
        continue;
      }
      csv << name << ',' << o.p_cam.x() << ',' << o.p_cam.y() << ',' << o.p_cam.z() << ',' << pose.x + tape(rng) << ','
          << pose.y + tape(rng) << ',' << std::max(0.0, pose.z + tape(rng)) << '\n';
      ++got;
    }
    if (missed > 0)
      spdlog::warn("{}: marker not detected in {} of {} placements (skipped)", name, missed, missed + got);
  }
  ips::cli::write_file_atomically(a.out, csv.str());
  std::printf("wrote %d pairs x %zu camera(s) to %s\n", a.points, cams.size(), a.out.c_str());
  return 0;
}

std::function<int()> setup_sim(CLI::App& sub) {
  sub.require_subcommand(1);
  auto r = std::make_shared<RenderArgs>();
  CLI::App* render = sub.add_subcommand("render", "Render every camera's frames plus a ground-truth JSON per frame");
  render->add_option("--scene", r->scene, "Scene YAML file")->required();
  render->add_option("--out", r->out, "Output directory (created)")->required();
  render->add_option("--frames", r->frames, "Number of frames")->capture_default_str();
  render->add_option("--fps", r->fps, "Frame rate: frame k is at scene time k / fps")->capture_default_str();
  render->add_option("--camera", r->cameras, "Only these cameras (repeatable; default all)");
  render->add_option("--jpeg-restart-rows", r->restart_rows,
                     "A restart marker every N MCU rows, as some cameras send (0 = none; default: the scene's "
                     "render.jpeg_restart_rows)");

  auto c = std::make_shared<CollectArgs>();
  CLI::App* collect = sub.add_subcommand(
      "collect", "Reproduce the calibration procedure: one marker at N random places per camera -> pairs CSV");
  collect->add_option("--scene", c->scene, "Scene YAML file")->required();
  collect->add_option("--points", c->points, "Pairs per camera")->capture_default_str();
  collect->add_option("--out", c->out, "Output CSV (camera,xc,yc,zc,xw,yw,zw)")->required();
  collect->add_option("--tape-noise", c->tape_noise, "Std-dev of the hand measurement of xw, yw, zw, metres")
      ->capture_default_str();
  collect->add_option("--max-height", c->max_height, "Marker heights drawn from [0, this], metres")
      ->capture_default_str();
  collect->add_option("--marker-length", c->marker_length, "Marker edge length, metres")->capture_default_str();
  collect->add_option("--seed", c->seed, "Random seed (placements and tape noise)")->capture_default_str();
  collect->add_option("--camera", c->cameras, "Only these cameras (repeatable; default all)");

  // `ips sim` subcommands in their own files (IPS_REGISTER_SIM_COMMAND).
  std::vector<std::pair<CLI::App*, std::function<int()>>> more;
  for (const auto& command : ips::cli::sim_registry()) {
    CLI::App* s = sub.add_subcommand(command.name, command.help);
    more.emplace_back(s, command.setup(*s));
  }

  return [render, collect, r, c, more]() -> int {
    if (render->parsed()) return run_render(*r);
    if (collect->parsed()) return run_collect(*c);
    for (const auto& [s, run] : more)
      if (s->parsed()) return run();
    return 2;
  };
}

}  // namespace cmd_sim

std::vector<ips::cli::Command>& ips::cli::sim_registry() {
  static std::vector<Command> commands;
  return commands;
}

namespace cmd_sim {  // named, not anonymous: unique in a unity build

IPS_REGISTER_COMMAND("sim", "Simulated cameras: render frames with ground truth, collect calibration pairs", setup_sim);

}  // namespace cmd_sim
