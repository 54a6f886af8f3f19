// `ips locate`: detect the markers in one image and print their camera coordinates.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/config/config.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/geometry/camera_model.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/mapping/model_file.h"

namespace cmd_locate {  // named, not anonymous: unique in a unity build

struct LocateArgs {
  std::string image;
  std::string intrinsics;
  double marker_length = 0.20;
  std::vector<std::string> marker_sizes;  // "ID=LENGTH"
  std::string dictionary = "DICT_4X4_100";
  std::string config;  // an ipsd configuration: its detection + markers sections
  std::string model;
  std::string camera;
  double height = 0.0;
  bool json = false;
};

ips::MarkerSizes parse_sizes(const LocateArgs& a) {
  ips::MarkerSizes sizes;
  if (!(a.marker_length > 0)) throw ips::InputError("--marker-length must be > 0");
  sizes.default_length = a.marker_length;
  for (const auto& s : a.marker_sizes) {
    const auto eq = s.find('=');
    try {
      if (eq == std::string::npos) throw std::invalid_argument("no '='");
      std::size_t used = 0;
      const int id = std::stoi(s.substr(0, eq), &used);
      if (used != eq) throw std::invalid_argument("id");
      const std::string len_text = s.substr(eq + 1);
      const double len = std::stod(len_text, &used);
      if (used != len_text.size() || !(len > 0) || id < 0) throw std::invalid_argument("value");
      sizes.by_id[id] = len;
    } catch (const std::exception&) {
      throw ips::InputError("--marker-size '" + s + "': expected ID=LENGTH_IN_METRES, e.g. 7=0.15");
    }
  }
  return sizes;
}

int run_locate(const LocateArgs& a) {
  ips::MarkerSizes sizes;
  ips::DetectorOptions options;
  if (!a.config.empty()) {  // the daemon's own settings, to see what it sees
    const ips::DaemonConfig config = ips::load_config(a.config);
    sizes = config.markers.sizes();
    options = config.detection;
  } else {
    sizes = parse_sizes(a);
    options.dictionary = a.dictionary;
  }
  const cv::Mat gray = ips::cli::read_gray_image(a.image);
  // Without intrinsics, a generic pinhole guess (focal length = the larger image side, ~53 deg
  // across it; principal point at the centre; no distortion): ids and pixel corners do not
  // depend on it, camera coordinates are only rough.
  const bool guessed = a.intrinsics.empty();
  const ips::CameraModel camera =
      guessed ? ips::CameraModel(ips::CameraModel::Kind::kPinhole, gray.size(),
                                 cv::Matx33d(std::max(gray.cols, gray.rows), 0, (gray.cols - 1) / 2.0, 0,
                                             std::max(gray.cols, gray.rows), (gray.rows - 1) / 2.0, 0, 0, 1),
                                 {0.0, 0.0, 0.0, 0.0})
              : ips::CameraModel::load(a.intrinsics);
  if (guessed) {
    std::fprintf(stderr,
                 "ips locate: no --intrinsics: assuming a pinhole camera with f = %d px and no "
                 "distortion; ids and pixel corners are exact, camera coordinates are rough\n",
                 std::max(gray.cols, gray.rows));
  }
  ips::ModelSet models;
  const ips::Mapper* mapper = nullptr;
  if (!a.model.empty()) {
    if (a.camera.empty()) throw ips::InputError("--model needs --camera NAME (the camera's entry in the model file)");
    models = ips::load_model_file(a.model);
    mapper = models.find(a.camera);
    if (mapper == nullptr) throw ips::InputError(a.model + ": no model for camera '" + a.camera + "'");
  } else if (!a.camera.empty()) {
    throw ips::InputError("--camera is only used with --model");
  }
  ips::Detector detector(options);
  if (gray.size() != camera.size()) {
    throw ips::InputError(a.image + ": image is " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                          " but the intrinsics " + a.intrinsics + " are for " + std::to_string(camera.size().width) +
                          "x" + std::to_string(camera.size().height));
  }
  // A guessed model would bend the fitted edges wrongly: refine in pixels then.
  const auto found = detector.detect(gray, guessed ? nullptr : &camera);
  nlohmann::json markers = nlohmann::json::array();
  if (!a.json) std::printf("%zu marker(s) in %s\n", found.size(), a.image.c_str());
  for (const auto& d : found) {
    const auto o = ips::locate_marker(d, camera, sizes.length_of(d.id));
    if (!std::isfinite(o.p_cam.z())) continue;  // a corner outside the lens model
    Eigen::Vector3d world = Eigen::Vector3d::Constant(std::nan(""));
    if (mapper != nullptr) world = mapper->predict(o.p_cam, mapper->needs_height() ? a.height : ips::Mapper::kNoHeight);
    if (a.json) {
      nlohmann::json corners = nlohmann::json::array();
      for (const auto& c : o.corners_px) corners.push_back({c.x, c.y});
      nlohmann::json m{{"id", o.id},        {"corners", corners}, {"xc", o.p_cam.x()}, {"yc", o.p_cam.y()},
                       {"zc", o.p_cam.z()}, {"yaw", o.yaw},       {"area", o.area_px}, {"length", o.edge_length}};
      if (mapper != nullptr) m["world"] = {world.x(), world.y(), world.z()};
      markers.push_back(m);
    } else {
      std::printf("id %3d  xc %+.4f  yc %+.4f  zc %.4f m  yaw %+7.2f deg  area %8.1f px^2", o.id, o.p_cam.x(),
                  o.p_cam.y(), o.p_cam.z(), o.yaw * 180.0 / M_PI, o.area_px);
      if (mapper != nullptr) std::printf("  world %.4f %.4f %.4f m", world.x(), world.y(), world.z());
      std::printf("  corners");
      for (const auto& c : o.corners_px) std::printf(" (%.2f, %.2f)", c.x, c.y);
      std::printf("\n");
    }
  }
  if (a.json) {
    std::printf(
        "%s\n",
        nlohmann::json{{"markers", markers}, {"intrinsics", guessed ? "guessed" : a.intrinsics}}.dump().c_str());
  }
  return 0;
}

IPS_REGISTER_COMMAND(
    "locate", "Detect ArUco markers in one image and print their camera coordinates",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<LocateArgs>();
      sub.add_option("--image", a->image, "Image file (JPEG, PNG, ...)")->required();
      sub.add_option("--intrinsics", a->intrinsics,
                     "Camera intrinsics (ipsd YAML or OpenCV calibration file); without it a "
                     "generic pinhole guess (ids and pixel corners exact, coordinates rough)");
      auto* length =
          sub.add_option("--marker-length", a->marker_length, "Marker edge length, metres")->capture_default_str();
      auto* size = sub.add_option("--marker-size", a->marker_sizes, "Per-marker edge length ID=METRES (repeatable)");
      auto* dict = sub.add_option("--dictionary", a->dictionary, "ArUco dictionary")->capture_default_str();
      sub.add_option("--config", a->config,
                     "An ipsd configuration: use its markers and detection settings (instead of "
                     "--marker-length, --marker-size, --dictionary)")
          ->excludes(length)
          ->excludes(size)
          ->excludes(dict);
      sub.add_option("--model", a->model, "Model file: also print world coordinates");
      sub.add_option("--camera", a->camera, "The camera's name in the model file");
      sub.add_option("--height", a->height, "Marker height for mappers that need it (plane), metres")
          ->capture_default_str();
      sub.add_flag("--json", a->json, "Print JSON instead of text");
      return [a] { return run_locate(*a); };
    });

}  // namespace cmd_locate
