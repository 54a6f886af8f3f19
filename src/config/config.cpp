// Assembles the daemon's configuration: each section is parsed by its stage (src/<stage>/parse_*.cpp);
// here are the document, the cross-section checks and the daemon's own keys (logging, status,
// watchdog, model_file).
#include "ips/config/config.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "body/parse_bodies.h"
#include "capture/parse_camera.h"
#include "config/attach_ros2_names.h"
#include "core/map_reader.h"
#include "detect/parse_detection.h"
#include "fusion/parse_fusion.h"
#include "geometry/parse_markers.h"
#include "input/parse_ranging.h"
#include "insideout/parse_robot_camera.h"
#include "ips/core/error.h"
#include "output/parse_output.h"
#include "web/parse_web.h"

namespace ips {

using namespace config_detail;

DaemonConfig parse_config(const std::string& text, const std::filesystem::path& path, ConfigChecks checks) {
  const std::string file = path.string();
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(file + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                     ": not valid YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw InputError(file + ": empty configuration");
  const std::filesystem::path base = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");

  MapReader r(root, "", file);
  DaemonConfig c;
  c.file = path;

  const YAML::Node cameras = r.node("cameras");
  if (!cameras || !cameras.IsSequence() || cameras.size() == 0)
    r.fail(cameras ? cameras : root, "cameras", "required: a non-empty list of cameras");
  if (cameras.size() > 32) r.fail(cameras, "cameras", "at most 32 cameras (the stream's camera mask is 32 bits)");
  std::set<std::string> names;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    c.cameras.push_back(parse_camera(cameras[i], static_cast<int>(i), base, file, checks.intrinsics_exist));
    if (cameras[i].IsMap() && cameras[i]["on_robot"]) {
      const std::string key = "cameras[" + std::to_string(i) + "].on_robot";
      c.on_robot[static_cast<int>(i)] = parse_on_robot(cameras[i]["on_robot"], key, base, file);
    }
    if (!names.insert(c.cameras.back().name).second)
      r.fail(cameras[i]["name"], "cameras[" + std::to_string(i) + "].name",
             "duplicate camera name '" + c.cameras.back().name + "'");
  }

  if (r.has("markers")) c.markers = parse_markers(r.node("markers"), file);
  if (r.has("detection")) c.detection = parse_detection(r.node("detection"), file, c.tracking);
  try {
    (void)dictionary_id(c.markers.dictionary);
  } catch (const InputError& e) {
    r.fail(root["markers"]["dictionary"], "markers.dictionary", e.what());
  }
  c.detection.dictionary = c.markers.dictionary;
  if (r.has("bodies")) c.bodies = parse_bodies(r.node("bodies"), c.markers, file);
  // A daemon whose cameras all ride on robots maps through the ceiling map alone.
  const bool overhead = c.on_robot.size() < c.cameras.size();
  r.get_path("model_file", c.model_file, base, overhead, checks.model_file_exists);

  if (r.has("fusion")) c.fusion = parse_fusion(r.node("fusion"), file);

  if (r.has("outputs")) {
    const YAML::Node outputs = r.node("outputs");
    if (!outputs.IsSequence()) r.fail(outputs, "outputs", "expected a list of outputs");
    for (std::size_t i = 0; i < outputs.size(); ++i)
      c.outputs.push_back(parse_output(outputs[i], static_cast<int>(i), file));
    // A MAVLink track restarts when the fusion's Kalman filter would (unless set explicitly).
    for (OutputConfig& o : c.outputs)
      if (std::isnan(o.mavlink.track_gap_s)) o.mavlink.track_gap_s = c.fusion.kalman_options.reset_after_s;
  }
  attach_ros2_names(c, root, file);

  if (r.has("logging")) {
    MapReader l(r.node("logging"), "logging", file);
    l.get("level", c.log_level);
    static const std::set<std::string> levels = {"trace", "debug", "info", "warn", "error"};
    if (!levels.count(c.log_level))
      l.fail(l.raw()["level"], "logging.level", "unknown value '" + c.log_level + "' (trace|debug|info|warn|error)");
    l.finish();
  }

  if (r.has("status")) {
    MapReader s(r.node("status"), "status", file);
    s.get_number("interval", c.status.interval_s, 0.0, false);
    s.get("socket", c.status.socket);
    s.finish();
  }

  if (r.has("web")) parse_web(r.node("web"), file, c.web);
  if (r.has("ranging")) {
    c.ranging = parse_ranging(r.node("ranging"), file);
    const YAML::Node tags = root["ranging"]["tags"];
    for (const auto& [id, tag] : c.ranging.tags) {
      const std::string name = "tag " + std::to_string(id);
      if (tag.on_body()) {
        const std::string& body =
            tag.body;  // (a structured binding cannot be captured before C++20's P1091 in clang 14)
        if (std::none_of(c.bodies.begin(), c.bodies.end(), [&](const BodyDef& b) { return b.name == body; }))
          r.fail(tags, "ranging.tags", name + "'s body '" + tag.body + "' is not in bodies:");
        continue;
      }
      if (c.markers.ids.count(tag.marker) && c.markers.ids.at(tag.marker).fixed)
        r.fail(tags, "ranging.tags", name + "'s marker " + std::to_string(tag.marker) + " is a fixed marker");
      // A body's marker is published inside its body only: its fixes would never be seen.
      for (const BodyDef& b : c.bodies)
        for (const auto& m : b.markers)
          if (m.id == tag.marker)
            r.fail(tags, "ranging.tags",
                   name + "'s marker " + std::to_string(tag.marker) + " belongs to body '" + b.name +
                       "': give the tag `body: " + b.name + "` and its `offset` in the body's frame");
    }
  }

  if (r.has("processing")) {
    MapReader w(r.node("processing"), "processing", file);
    w.get("workers", c.processing.workers);
    if (c.processing.workers < 0 || c.processing.workers > 64)
      w.fail(w.raw()["workers"], "processing.workers", "must be 0..64 (0 = one per core)");
    w.get_number("budget", c.processing.budget_s, 0.0, false);
    if (c.processing.budget_s > 10)
      w.fail(w.raw()["budget"], "processing.budget", "must be <= 10 seconds (0 = one frame period)");
    w.finish();
  }

  if (r.has("watchdog")) {
    MapReader w(r.node("watchdog"), "watchdog", file);
    w.get_number("stall_timeout", c.stall_timeout_s, 0.0, true);
    w.finish();
  }
  r.finish();
  return c;
}

DaemonConfig load_config(const std::filesystem::path& path, ConfigChecks checks) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot read the configuration file");
  std::stringstream text;
  text << in.rdbuf();
  return parse_config(text.str(), path, checks);
}

}  // namespace ips
