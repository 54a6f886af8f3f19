#include "ips/sim/scene.h"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>
#include <opencv2/aruco.hpp>

#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "sim/scene_reader.h"

namespace ips::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Vector2d vec2(const std::vector<double>& v) { return {v[0], v[1]}; }

// A placements trajectory: poses [x, y], [x, y, height] or [x, y, height, yaw_deg] (the
// marker's own height / yaw_deg where left out) and the control file (relative to the scene).
void read_placements(const SceneReader& r, const YAML::Node& n, const std::string& path,
                     const std::filesystem::path& scene_dir, const MarkerPose& start, Trajectory& t) {
  const std::string control = r.text(n, path, "control", "");
  if (control.empty()) r.fail(n, path + "control", "missing (the file that holds the index)");
  t.control = std::filesystem::path(control).is_absolute() ? std::filesystem::path(control) : scene_dir / control;
  const YAML::Node pts = n["points"];
  if (!pts || !pts.IsSequence() || pts.size() < 1) {
    r.fail(pts ? pts : n, path + "points", "expected a list of [x, y(, height(, yaw_deg))] poses");
  }
  for (std::size_t i = 0; i < pts.size(); ++i) {
    YAML::Node holder;
    holder["p"] = pts[i];
    const std::string key = path + "points[" + std::to_string(i) + "]";
    const auto v = r.numbers(holder, key, "p", 2, 4);
    MarkerPose pose = start;
    pose.x = v[0];
    pose.y = v[1];
    if (v.size() > 2) pose.z = v[2];
    if (v.size() > 3) pose.yaw = v[3] * kDeg;
    if (pose.z < 0) r.fail(pts[i], key, "height must be >= 0");
    t.placements.push_back(pose);
  }
}

Trajectory read_trajectory(const SceneReader& r, const YAML::Node& n, const std::string& path,
                           const std::filesystem::path& scene_dir, const MarkerPose& start) {
  r.only_keys(n, path,
              {"type", "speed", "center", "radius", "clockwise", "from", "to", "points", "heading", "control", "pause",
               "start_deg"});
  Trajectory t;
  const std::string type = r.text(n, path, "type", "");
  if (type == "placements") {
    t.kind = Trajectory::Kind::kPlacements;
    read_placements(r, n, path, scene_dir, start, t);
    return t;
  }
  t.speed = r.number(n, path, "speed", 0.0, true);
  if (t.speed < 0) r.fail(n["speed"], path + "speed", "must be >= 0");
  const std::string heading = r.text(n, path, "heading", "path");
  if (heading != "path" && heading != "fixed") r.fail(n["heading"], path + "heading", "expected path or fixed");
  t.heading_follows_path = heading == "path";
  if (type == "circle") {
    t.kind = Trajectory::Kind::kCircle;
    t.center = vec2(r.numbers(n, path, "center", 2, 2));
    t.radius = r.number(n, path, "radius", 0.0, true);
    t.start_angle = r.number(n, path, "start_deg", 0.0) * kDeg;
    if (!(t.radius > 0)) r.fail(n["radius"], path + "radius", "must be > 0");
    if (n["clockwise"]) {
      try {
        t.clockwise = n["clockwise"].as<bool>();
      } catch (const YAML::Exception&) {
        r.fail(n["clockwise"], path + "clockwise", "expected true or false");
      }
    }
  } else if (type == "line") {
    t.kind = Trajectory::Kind::kLine;
    t.points = {vec2(r.numbers(n, path, "from", 2, 2)), vec2(r.numbers(n, path, "to", 2, 2))};
    if ((t.points[1] - t.points[0]).norm() < 1e-9) r.fail(n["to"], path + "to", "equals 'from'");
  } else if (type == "waypoints") {
    t.kind = Trajectory::Kind::kWaypoints;
    t.pause = r.number(n, path, "pause", 0.0, false);
    if (!(t.pause >= 0)) r.fail(n["pause"], path + "pause", "must be >= 0 seconds");
    const YAML::Node pts = n["points"];
    if (!pts || !pts.IsSequence() || pts.size() < 2) {
      r.fail(pts ? pts : n, path + "points", "expected a list of at least 2 [x, y] points");
    }
    for (std::size_t i = 0; i < pts.size(); ++i) {
      YAML::Node holder;
      holder["p"] = pts[i];
      t.points.push_back(vec2(r.numbers(holder, path + "points[" + std::to_string(i) + "]", "p", 2, 2)));
    }
  } else {
    r.fail(n["type"] ? n["type"] : n, path + "type",
           "expected circle, line, waypoints or placements, got '" + type + "'");
  }
  return t;
}

// bodies: each a body definition (ips/body/body.h) plus its start pose (x, y, height of the origin,
// yaw_deg, roll_deg, pitch_deg) and an optional trajectory; its markers join scene.markers.
void read_bodies(const SceneReader& r, const YAML::Node& bs, const std::filesystem::path& scene_dir,
                 int dictionary_size, Scene& scene) {
  if (!bs.IsSequence()) r.fail(bs, "bodies", "expected a list");
  const BodyFail fail = [&](const YAML::Node& at, const std::string& key, const std::string& what) {
    r.fail(at, key, what);
  };
  std::vector<YAML::Node> nodes;
  std::vector<BodyDef> defs;
  for (std::size_t i = 0; i < bs.size(); ++i) {
    const YAML::Node b = bs[i];
    const std::string p = "bodies[" + std::to_string(i) + "]";
    SceneBody body;
    body.def = parse_body(b, p, {"x", "y", "height", "yaw_deg", "roll_deg", "pitch_deg", "trajectory"}, fail);
    const std::string q = p + ".";
    body.start.x = r.number(b, q, "x", 0, !b["trajectory"]);
    body.start.y = r.number(b, q, "y", 0, !b["trajectory"]);
    body.start.z = r.number(b, q, "height", 0.0);
    body.start.yaw = r.number(b, q, "yaw_deg", 0.0) * kDeg;
    body.roll = r.number(b, q, "roll_deg", 0.0) * kDeg;
    body.pitch = r.number(b, q, "pitch_deg", 0.0) * kDeg;
    if (b["trajectory"])
      body.trajectory = read_trajectory(r, b["trajectory"], q + "trajectory.", scene_dir, body.start);
    if (body.trajectory.kind == Trajectory::Kind::kPlacements)
      r.fail(b["trajectory"], q + "trajectory.type", "placements are for single markers, not bodies");
    for (const BodyMarker& bm : body.def.markers) {
      if (bm.id >= dictionary_size)
        r.fail(b, p, "marker id " + std::to_string(bm.id) + " is not in " + scene.dictionary);
      for (const auto& plain : scene.markers) {
        if (plain.body < 0 && plain.id == bm.id)
          r.fail(b, p, "marker id " + std::to_string(bm.id) + " is also a plain marker of the scene");
      }
      SceneMarker mk;
      mk.id = bm.id;
      mk.length = bm.edge;
      mk.margin = (bm.plate - bm.edge) / 2.0 > 0 ? (bm.plate - bm.edge) / 2.0 : -1.0;
      mk.body = static_cast<int>(scene.bodies.size());
      mk.on_body = bm;
      scene.markers.push_back(mk);
    }
    nodes.push_back(b);
    defs.push_back(body.def);
    scene.bodies.push_back(std::move(body));
  }
  check_bodies(defs, nodes, "bodies", fail);
}

}  // namespace

Eigen::Matrix3d Scene::orientation(double roll, double pitch, double yaw, bool up) {
  Eigen::Matrix3d down;
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // columns: camera x = world x, y = -world y, z = down
  if (up) down.setIdentity();           // camera x = world x, y = world y, z = up
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
             .toRotationMatrix() *
         down;
}

Scene Scene::load(const std::filesystem::path& path) {
  const std::string file = path.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw InputError(file + ": cannot open scene file");
  } catch (const YAML::Exception& e) {
    throw InputError(file + ":" + std::to_string(e.mark.line + 1) + ": YAML error: " + e.msg);
  }
  const SceneReader r(file);
  r.only_keys(
      root, "",
      {"dictionary", "floor", "render", "cameras", "markers", "lamps", "bodies", "anchors", "nlos_zones", "tags"});
  Scene scene;
  scene.dictionary = r.text(root, "", "dictionary", scene.dictionary);
  try {
    dictionary_id(scene.dictionary);
  } catch (const InputError& e) {
    r.fail(root["dictionary"], "dictionary", e.what());
  }

  if (const YAML::Node f = root["floor"]) {
    r.only_keys(f, "floor.", {"size", "grey", "texture_contrast", "texture_scale", "seed"});
    if (f["size"]) {
      const auto s = r.numbers(f, "floor.", "size", 2, 2);
      if (!(s[0] > 0 && s[1] > 0)) r.fail(f["size"], "floor.size", "must be positive");
      scene.floor.size_x = s[0];
      scene.floor.size_y = s[1];
    }
    scene.floor.grey = r.number(f, "floor.", "grey", scene.floor.grey);
    scene.floor.texture_contrast = r.number(f, "floor.", "texture_contrast", scene.floor.texture_contrast);
    scene.floor.texture_scale = r.number(f, "floor.", "texture_scale", scene.floor.texture_scale);
    if (!(scene.floor.texture_scale > 0)) r.fail(f["texture_scale"], "floor.texture_scale", "must be > 0");
    scene.floor.seed = static_cast<unsigned>(r.integer(f, "floor.", "seed", scene.floor.seed, 0, 4294967295.0));
  }

  if (const YAML::Node g = root["render"]) {
    auto& s = scene.render;
    r.only_keys(g, "render.",
                {"supersample", "noise_sigma", "jpeg_quality", "jpeg_restart_rows", "vignetting", "gradient",
                 "exposure", "blur_samples", "white", "black", "seed"});
    s.supersample = static_cast<int>(r.integer(g, "render.", "supersample", s.supersample, 1, 8));
    s.noise_sigma = r.number(g, "render.", "noise_sigma", s.noise_sigma);
    if (s.noise_sigma < 0 || s.noise_sigma > 50) r.fail(g["noise_sigma"], "render.noise_sigma", "must be 0..50");
    s.jpeg_quality = static_cast<int>(r.integer(g, "render.", "jpeg_quality", s.jpeg_quality, 0, 100));
    s.jpeg_restart_rows = static_cast<int>(r.integer(g, "render.", "jpeg_restart_rows", s.jpeg_restart_rows, 0, 255));
    s.vignetting = r.number(g, "render.", "vignetting", s.vignetting);
    if (s.vignetting < 0 || s.vignetting >= 1) r.fail(g["vignetting"], "render.vignetting", "must be in [0, 1)");
    s.gradient = r.number(g, "render.", "gradient", s.gradient);
    if (std::abs(s.gradient) >= 1) r.fail(g["gradient"], "render.gradient", "must be in (-1, 1)");
    s.exposure = r.number(g, "render.", "exposure", s.exposure);
    if (s.exposure < 0 || s.exposure > 1) r.fail(g["exposure"], "render.exposure", "must be 0..1 s");
    s.blur_samples = static_cast<int>(r.integer(g, "render.", "blur_samples", s.blur_samples, 1, 64));
    s.white = r.number(g, "render.", "white", s.white);
    s.black = r.number(g, "render.", "black", s.black);
    if (!(s.black >= 0 && s.white <= 255 && s.white > s.black + 20)) {
      r.fail(g, "render.white/black", "need 0 <= black < white - 20 <= 235");
    }
    s.seed = static_cast<unsigned>(r.integer(g, "render.", "seed", s.seed, 0, 4294967295.0));
  }

  // A scene of ranges only (anchors, no cameras) is allowed; one with neither simulates nothing.
  const YAML::Node cams = root["cameras"];
  if (cams ? !cams.IsSequence() || cams.size() == 0 : !root["anchors"]) {
    r.fail(cams ? cams : root, "cameras", "expected a non-empty list of cameras");
  }
  for (std::size_t i = 0; cams && i < cams.size(); ++i) {
    const YAML::Node c = cams[i];
    const std::string p = "cameras[" + std::to_string(i) + "].";
    r.only_keys(c, p, {"name", "intrinsics", "position", "rotation_deg", "looking", "trajectory"});
    SceneCamera cam;
    cam.name = r.text(c, p, "name", "");
    if (cam.name.empty()) r.fail(c, p + "name", "missing");
    for (const auto& other : scene.cameras) {
      if (other.name == cam.name) r.fail(c["name"], p + "name", "duplicate camera name '" + cam.name + "'");
    }
    const std::string intr = r.text(c, p, "intrinsics", "");
    if (intr.empty()) r.fail(c, p + "intrinsics", "missing");
    cam.intrinsics_path =
        std::filesystem::path(intr).is_absolute() ? std::filesystem::path(intr) : path.parent_path() / intr;
    try {
      cam.model = CameraModel::load(cam.intrinsics_path);
    } catch (const InputError& e) {
      r.fail(c["intrinsics"], p + "intrinsics", e.what());
    }
    const std::string looking = r.text(c, p, "looking", "down");
    if (looking != "down" && looking != "up") r.fail(c["looking"], p + "looking", "expected down or up");
    cam.looks_up = looking == "up";
    cam.rides = static_cast<bool>(c["trajectory"]);
    const auto pos = r.numbers(c, p, "position", cam.rides ? 1 : 2, 3);
    if (cam.rides && pos.size() != 1 && pos.size() != 3) {
      r.fail(c["position"], p + "position",
             "a riding camera takes [height] or [x, y, height] (x, y: where the robot starts)");
    }
    cam.position = pos.size() == 1 ? Eigen::Vector3d(0, 0, pos[0])
                                   : Eigen::Vector3d(pos[0], pos[1], pos.size() > 2 ? pos[2] : 2.1);
    if (cam.looks_up ? !(cam.position.z() >= 0) : !(cam.position.z() > 0.3)) {
      r.fail(c["position"], p + "position",
             cam.looks_up ? "the lens must be at or above the floor" : "camera must be > 0.3 m above the floor");
    }
    std::vector<double> rot{0, 0, 0};
    if (c["rotation_deg"]) rot = r.numbers(c, p, "rotation_deg", 3, 3);
    cam.R_wc = orientation(rot[0] * kDeg, rot[1] * kDeg, rot[2] * kDeg, cam.looks_up);
    if (cam.rides) {
      // rotation_deg is then the mount on the robot (x forward, y left, z up).
      cam.R_mount = cam.R_wc;
      cam.carrier_start.x = cam.position.x();
      cam.carrier_start.y = cam.position.y();
      cam.carrier = read_trajectory(r, c["trajectory"], p + "trajectory.", path.parent_path(), cam.carrier_start);
      if (cam.carrier.kind == Trajectory::Kind::kPlacements) {
        r.fail(c["trajectory"], p + "trajectory", "a camera rides a circle, line or waypoints, not placements");
      }
    }
    scene.cameras.push_back(std::move(cam));
  }

  const int dictionary_size = cv::aruco::getPredefinedDictionary(dictionary_id(scene.dictionary))->bytesList.rows;
  if (const YAML::Node ms = root["markers"]) {
    if (!ms.IsSequence()) r.fail(ms, "markers", "expected a list");
    for (std::size_t i = 0; i < ms.size(); ++i) {
      const YAML::Node m = ms[i];
      const std::string p = "markers[" + std::to_string(i) + "].";
      r.only_keys(m, p, {"id", "length", "margin", "x", "y", "height", "yaw_deg", "trajectory", "facing"});
      SceneMarker mk;
      const double id = r.number(m, p, "id", 0, true);
      if (id < 0 || id != std::floor(id) || id > 1e9)  // beyond int: the cast would be undefined
        r.fail(m["id"], p + "id", "must be a non-negative integer");
      mk.id = static_cast<int>(id);
      if (mk.id >= dictionary_size) {
        r.fail(m["id"], p + "id", "not in " + scene.dictionary + " (0.." + std::to_string(dictionary_size - 1) + ")");
      }
      for (const auto& other : scene.markers) {
        if (other.id == mk.id) r.fail(m["id"], p + "id", "duplicate marker id " + std::to_string(mk.id));
      }
      mk.length = r.number(m, p, "length", mk.length);
      if (!(mk.length > 0.005 && mk.length < 5)) r.fail(m["length"], p + "length", "must be 0.005..5 m");
      mk.margin = r.number(m, p, "margin", mk.margin);
      mk.start.x = r.number(m, p, "x", 0, !m["trajectory"]);
      mk.start.y = r.number(m, p, "y", 0, !m["trajectory"]);
      mk.start.z = r.number(m, p, "height", 0.0);
      if (mk.start.z < 0) r.fail(m["height"], p + "height", "must be >= 0");
      mk.start.yaw = r.number(m, p, "yaw_deg", 0.0) * kDeg;
      if (m["trajectory"]) {
        mk.trajectory = read_trajectory(r, m["trajectory"], p + "trajectory.", path.parent_path(), mk.start);
      }
      const std::string facing = r.text(m, p, "facing", "up");
      if (facing != "up" && facing != "down") r.fail(m["facing"], p + "facing", "expected up or down");
      if (facing == "down") {
        // On the ceiling, printed side down: seen from below it reads as printed, its x axis at
        // yaw (ips/insideout/ceiling_map.h has the same convention).
        if (m["trajectory"]) r.fail(m["facing"], p + "facing", "a marker facing down is fixed (no trajectory)");
        const double c = std::cos(mk.start.yaw), s = std::sin(mk.start.yaw);
        mk.start.tilted = true;
        mk.start.axes.col(0) = Eigen::Vector3d(c, s, 0);
        mk.start.axes.col(2) = Eigen::Vector3d(0, 0, -1);
        mk.start.axes.col(1) = mk.start.axes.col(2).cross(mk.start.axes.col(0));
      }
      scene.markers.push_back(mk);
    }
  }
  if (const YAML::Node bs = root["bodies"]) read_bodies(r, bs, path.parent_path(), dictionary_size, scene);
  read_ranging(r, root, scene);
  read_lamps(r, root, scene);
  return scene;
}

std::size_t Scene::camera_index(const std::string& name) const {
  std::string names;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].name == name) return i;
    names += (names.empty() ? "" : ", ") + cameras[i].name;
  }
  throw InputError("scene has no camera '" + name + "' (cameras: " + names + ")");
}

}  // namespace ips::sim
