#include "ips/config.h"

#include <arpa/inet.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "ips/error.h"
#include "ips/fusion.h"
#include "map_reader.h"

namespace ips {

const char* to_string(SourceKind kind) {
  switch (kind) {
    case SourceKind::kV4l2: return "v4l2";
    case SourceKind::kFile: return "file";
    case SourceKind::kSynthetic: return "synthetic";
  }
  return "?";
}

const char* to_string(CaptureFormat format) { return format == CaptureFormat::kMjpeg ? "MJPEG" : "YUYV"; }

MarkerSizes MarkerConfig::sizes() const {
  MarkerSizes s;
  s.default_length = edge_length;
  for (const auto& [id, info] : ids)
    if (!std::isnan(info.edge_length)) s.by_id[id] = info.edge_length;
  return s;
}

double MarkerConfig::height_of(int id) const {
  auto it = ids.find(id);
  if (it != ids.end() && !std::isnan(it->second.height)) return it->second.height;
  return height;
}

bool MarkerConfig::published(int id) const {
  auto it = ids.find(id);
  return it == ids.end() || it->second.publish;
}

std::string OutputConfig::describe() const {
  if (kind == Kind::kRos2) return "ros2 domain " + std::to_string(ros2.domain) + " /" + ros2.prefix;
  const std::string where = address + ":" + std::to_string(port);
  switch (kind) {
    case Kind::kMavlink: return "mavlink " + where + " (" + std::to_string(mavlink.vehicles.size()) + " vehicle(s))";
    case Kind::kSubscriptions: return "subscriptions on " + where;
    default: break;
  }
  const char* kinds[] = {"unicast", "broadcast", "multicast"};
  return std::string(kinds[static_cast<int>(kind)]) + " " + where + " (" + to_string(format) + ")";
}

namespace {

using config_detail::MapReader;
using config_detail::parse_output;
using config_detail::pick;

CameraConfig parse_camera(const YAML::Node& n, int index, const std::filesystem::path& base, const std::string& file,
                          ConfigChecks checks) {
  MapReader r(n, "cameras[" + std::to_string(index) + "]", file);
  CameraConfig c;
  c.index = index;
  r.get("name", c.name, true);
  if (c.name.empty()) r.fail(n["name"], r.key("name"), "empty name");
  c.model = c.name;
  r.get("model", c.model);
  c.source = pick<SourceKind>(r, "source",
                              {{"v4l2", SourceKind::kV4l2}, {"file", SourceKind::kFile}, {"synthetic", SourceKind::kSynthetic}},
                              c.source, true);
  r.get("device", c.device, c.source == SourceKind::kV4l2);
  r.get("width", c.width);
  r.get("height", c.height);
  if (c.width <= 0 || c.height <= 0) r.fail(n, r.key("width/height"), "must be positive");
  c.pixel_format = pick<CaptureFormat>(r, "pixel_format", {{"MJPEG", CaptureFormat::kMjpeg}, {"YUYV", CaptureFormat::kYuyv}},
                                       c.pixel_format, false);
  r.get("buffer_count", c.buffer_count);
  if (c.buffer_count < 4) r.fail(n["buffer_count"], r.key("buffer_count"), "must be >= 4");
  if (r.has("controls")) {
    MapReader k(r.node("controls"), r.key("controls"), file);
    auto opt = [&k](const std::string& key, auto& field) {
      using T = typename std::remove_reference_t<decltype(field)>::value_type;
      if (!k.has(key)) return;
      T v{};
      k.get(key, v);
      field = v;
    };
    opt("auto_exposure", c.auto_exposure);
    opt("exposure", c.exposure_s);
    // Seconds, not the V4L2 100-us units: a value like 150 is almost surely a unit mistake.
    if (c.exposure_s && !(*c.exposure_s > 0 && *c.exposure_s <= 1.0))
      k.fail(k.raw()["exposure"], k.key("exposure"), "must be in (0, 1] seconds");
    opt("gain", c.gain);
    opt("autofocus", c.autofocus);
    opt("power_line_hz", c.power_line_hz);
    if (c.power_line_hz && *c.power_line_hz != 0 && *c.power_line_hz != 50 && *c.power_line_hz != 60)
      k.fail(k.raw()["power_line_hz"], k.key("power_line_hz"), "must be 50, 60 or 0");
    k.finish();
  }
  r.get_path("path", c.path, base, c.source == SourceKind::kFile);
  r.get("loop", c.loop);
  r.get("preload", c.preload);
  r.get_path("scene", c.scene, base, c.source == SourceKind::kSynthetic);
  c.scene_camera = c.name;
  r.get("scene_camera", c.scene_camera);
  r.get_number("fps", c.fps, 0.0, true);
  r.get_path("intrinsics", c.intrinsics, base, c.source != SourceKind::kSynthetic, checks.intrinsics_exist);
  r.get("required", c.required);
  r.get("timestamp_offset", c.timestamp_offset_s);
  if (r.has("timestamp_offset") && !(std::fabs(c.timestamp_offset_s) <= 1.0))
    r.fail(n["timestamp_offset"], r.key("timestamp_offset"), "must be within [-1, 1] seconds");
  r.get_number("phase", c.phase_s, 0.0, false);
  if (c.phase_s >= 1.0) r.fail(n["phase"], r.key("phase"), "must be < 1 second");
  if (r.has("transport_delay")) {
    double delay = 0.0;
    r.get_number("transport_delay", delay, 0.0, false);
    if (delay > 1.0) r.fail(n["transport_delay"], r.key("transport_delay"), "must be <= 1 second");
    c.transport_delay_s = delay;
  }
  r.finish();
  return c;
}

MarkerConfig parse_markers(const YAML::Node& n, const std::string& file) {
  MapReader r(n, "markers", file);
  MarkerConfig m;
  r.get("dictionary", m.dictionary);
  r.get_number("edge_length", m.edge_length, 0.0, true);
  if (r.has("height")) r.get("height", m.height);
  if (r.has("ids")) {
    const YAML::Node ids = r.node("ids");
    if (!ids.IsMap()) r.fail(ids, "markers.ids", "expected a mapping of marker id -> settings");
    for (const auto& kv : ids) {
      int id = -1;
      if (!kv.first.IsScalar()) r.fail(kv.first, "markers.ids", "marker id must be a non-negative integer");
      const std::string id_text = kv.first.as<std::string>();
      try {
        id = kv.first.as<int>();
      } catch (const YAML::Exception&) {
        r.fail(kv.first, "markers.ids." + id_text, "marker id must be a non-negative integer");
      }
      if (id < 0) r.fail(kv.first, "markers.ids." + id_text, "marker id must be a non-negative integer");
      MapReader e(kv.second, "markers.ids." + id_text, file);
      MarkerInfo info;
      e.get("name", info.name);
      if (e.has("edge_length")) e.get_number("edge_length", info.edge_length, 0.0, true);
      if (e.has("height")) e.get("height", info.height);
      if (e.has("fixed")) {
        const YAML::Node f = e.node("fixed");
        std::array<double, 3> p{};
        bool ok = f.IsSequence() && f.size() == 3;
        for (std::size_t i = 0; ok && i < 3; ++i) {
          try {
            p[i] = f[i].as<double>();
            ok = f[i].IsScalar() && std::isfinite(p[i]);
          } catch (const YAML::Exception&) {
            ok = false;
          }
        }
        if (!ok) e.fail(f, e.key("fixed"), "expected [x, y, z]: three finite numbers (world metres)");
        info.fixed = p;
        // A fixed marker's height is known: its surveyed z (unless given explicitly).
        if (std::isnan(info.height)) info.height = p[2];
      }
      info.publish = !info.fixed;  // fixed markers are not robots unless configured to be
      e.get("publish", info.publish);
      e.finish();
      m.ids[id] = info;
    }
  }
  r.finish();
  return m;
}

// detection: the detector's tuning (DetectorOptions); the dictionary comes from markers.
// Also the tracking keys (#12), into `tracking`.
DetectorOptions parse_detection(const YAML::Node& n, const std::string& file, TrackerOptions& tracking) {
  MapReader r(n, "detection", file);
  DetectorOptions d;
  auto int_in = [&](const std::string& k, int& value, int lo, int hi) {
    r.get(k, value);
    if (r.has(k) && (value < lo || value > hi))
      r.fail(r.raw()[k], r.key(k), "must be " + std::to_string(lo) + ".." + std::to_string(hi));
  };
  auto number_in = [&](const std::string& k, double& value, double lo, double hi) {
    r.get(k, value);
    if (r.has(k) && !(value >= lo && value <= hi)) {
      std::ostringstream range;
      range << lo << ".." << hi;
      r.fail(r.raw()[k], r.key(k), "must be " + range.str());
    }
  };
  int_in("detect_scale", d.detect_scale, 0, 8);
  number_in("min_marker_px", d.min_marker_px, 0.0, 100000.0);
  if (r.has("min_perimeter_px")) {  // the older form of min_marker_px: 4 sides
    double perimeter = 0;
    r.get_number("min_perimeter_px", perimeter, 0.0, true);
    if (r.has("min_marker_px"))
      r.fail(r.raw()["min_perimeter_px"], r.key("min_perimeter_px"), "give min_marker_px only");
    d.min_marker_px = perimeter / 4;
  }
  if (r.has("threshold_windows")) {
    const YAML::Node w = r.node("threshold_windows");
    if (!w.IsSequence() || w.size() == 0)
      r.fail(w, "detection.threshold_windows", "expected a non-empty list of odd window sizes, e.g. [9] or [9, 19]");
    d.threshold_windows.clear();
    for (std::size_t i = 0; i < w.size(); ++i) {
      const std::string key = "detection.threshold_windows[" + std::to_string(i) + "]";
      int v = 0;
      try {
        v = w[i].as<int>();
      } catch (const YAML::Exception&) {
        r.fail(w[i], key, "expected an integer");
      }
      if (v < 3 || v % 2 == 0 || v > 255) r.fail(w[i], key, "window sizes must be odd, 3..255");
      d.threshold_windows.push_back(v);
    }
  }
  number_in("threshold_constant", d.threshold_constant, 0.0, 255.0);
  r.get_number("max_perimeter_rate", d.max_perimeter_rate, 0.0, true);
  number_in("error_correction_rate", d.error_correction_rate, 0.0, 1.0);
  number_in("max_border_error_rate", d.max_border_error_rate, 0.0, 1.0);
  int_in("max_ambiguous_cells", d.max_ambiguous_cells, -1, 1000);
  number_in("cell_ambiguity", d.cell_ambiguity, 0.0, 0.5);
  int_in("min_clear_margin", d.min_clear_margin, 1, 64);
  number_in("min_contrast", d.min_contrast, 0.0, 255.0);
  d.refinement = pick<CornerRefinement>(
      r, "refinement",
      {{"edges", CornerRefinement::kEdges}, {"subpix", CornerRefinement::kSubPix}, {"none", CornerRefinement::kNone}},
      d.refinement, false);
  int_in("refine_half_window_px", d.refine_half_window_px, 1, 32);
  r.get("tracking", tracking.enabled);
  int_in("full_search_period", tracking.full_search_period, 1, 1000);
  number_in("roi_margin", tracking.roi_margin, 0.25, 100.0);
  r.finish();
  return d;
}

}  // namespace

/// web: {listen: "127.0.0.1:8080", ...}. The address is checked here so that a typo stops
/// the start (exit 2) with the key's place rather than failing in the server.
static void parse_web(const YAML::Node& node, const std::string& file, WebConfig& w) {
  MapReader r(node, "web", file);
  r.get("listen", w.listen, true);
  const auto colon = w.listen.rfind(':');
  const std::string host = colon == std::string::npos ? "" : w.listen.substr(0, colon);
  const std::string port = colon == std::string::npos ? "" : w.listen.substr(colon + 1);
  in_addr addr{};
  if (host.empty() || (host != "localhost" && ::inet_pton(AF_INET, host.c_str(), &addr) != 1))
    r.fail(r.raw()["listen"], "web.listen", "expected IPV4-ADDRESS:PORT (e.g. 127.0.0.1:8080), got '" + w.listen + "'");
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || p < 1 || p > 65535)
    r.fail(r.raw()["listen"], "web.listen", "port must be 1..65535, got '" + port + "'");
  w.host = host == "localhost" ? "127.0.0.1" : host;
  w.port = static_cast<int>(p);
  r.get_number("update_rate", w.update_rate_hz, 0.0, true);
  if (w.update_rate_hz > 100) r.fail(r.raw()["update_rate"], "web.update_rate", "must be <= 100 (Hz)");
  r.get_number("camera_fps", w.camera_fps, 0.0, true);
  if (w.camera_fps > 30) r.fail(r.raw()["camera_fps"], "web.camera_fps", "must be <= 30");
  r.get("image_width", w.image_width);
  if (w.image_width < 160 || w.image_width > 4096)
    r.fail(r.raw()["image_width"], "web.image_width", "must be 160..4096 (pixels)");
  r.get("max_clients", w.max_clients);
  if (w.max_clients < 1 || w.max_clients > 256)
    r.fail(r.raw()["max_clients"], "web.max_clients", "must be 1..256");
  r.get("max_connections", w.max_connections);
  if (w.max_connections < 16 || w.max_connections > 1024)
    r.fail(r.raw()["max_connections"], "web.max_connections", "must be 16..1024");
  r.get("max_per_address", w.max_per_address);
  if (w.max_per_address < 1 || w.max_per_address > 256)
    r.fail(r.raw()["max_per_address"], "web.max_per_address", "must be 1..256");
  r.get_number("request_timeout", w.request_timeout_s, 0.0, true);
  if (w.request_timeout_s < 0.2 || w.request_timeout_s > 60)
    r.fail(r.raw()["request_timeout"], "web.request_timeout", "must be 0.2..60 (seconds)");
  if (r.has("floor")) {
    const YAML::Node f = r.node("floor");
    bool ok = f.IsSequence() && f.size() == 4;
    for (std::size_t i = 0; ok && i < 4; ++i) {
      try {
        w.floor.push_back(f[i].as<double>());
        ok = std::isfinite(w.floor.back());
      } catch (const YAML::Exception&) {
        ok = false;
      }
    }
    if (!ok || !(w.floor[0] < w.floor[2] && w.floor[1] < w.floor[3]))
      r.fail(f, "web.floor", "expected [xmin, ymin, xmax, ymax] in metres with xmin < xmax, ymin < ymax");
  }
  r.finish();
}

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
    c.cameras.push_back(parse_camera(cameras[i], static_cast<int>(i), base, file, checks));
    if (!names.insert(c.cameras.back().name).second)
      r.fail(cameras[i]["name"], "cameras[" + std::to_string(i) + "].name", "duplicate camera name '" + c.cameras.back().name + "'");
  }

  if (r.has("markers")) c.markers = parse_markers(r.node("markers"), file);
  if (r.has("detection")) c.detection = parse_detection(r.node("detection"), file, c.tracking);
  try {
    (void)dictionary_id(c.markers.dictionary);
  } catch (const InputError& e) {
    r.fail(root["markers"]["dictionary"], "markers.dictionary", e.what());
  }
  c.detection.dictionary = c.markers.dictionary;
  if (r.has("bodies")) c.bodies = config_detail::parse_bodies(r.node("bodies"), c.markers, file);
  r.get_path("model_file", c.model_file, base, true, checks.model_file_exists);

  if (r.has("fusion")) {
    MapReader f(r.node("fusion"), "fusion", file);
    f.get("method", c.fusion.method);
    try {
      (void)find_fusion_method(c.fusion.method, "fusion.method");
    } catch (const InputError&) {
      std::string known;
      for (const auto& m : fusion_methods()) known += (known.empty() ? "" : "|") + m.name;
      f.fail(f.raw()["method"], "fusion.method", "unknown method '" + c.fusion.method + "' (" + known + ")");
    }
    f.get_number("window", c.fusion.window_s, 0.0, false);
    f.get_number("velocity_span", c.fusion.velocity_span_s, 0.0, false);
    f.get_number("history", c.fusion.history_s, 0.0, true);
    if (c.fusion.history_s < c.fusion.window_s)
      f.fail(f.has("history") ? f.raw()["history"] : f.raw(), "fusion.history", "must be >= fusion.window");
    f.get("single_camera_depth", c.fusion.single_camera_depth);
    f.get_number("output_rate", c.fusion.output_rate_hz, 0.0, false);
    if (c.fusion.output_rate_hz > 1000)
      f.fail(f.raw()["output_rate"], "fusion.output_rate", "must be <= 1000 Hz (0 = one update per camera frame)");
    f.get_number("max_wait", c.fusion.max_wait_s, 0.0, true);
    f.get_number("fixed_marker_warn", c.fusion.fixed_marker_warn_m, 0.0, true);
    if (f.has("kalman")) {
      MapReader k(f.node("kalman"), "fusion.kalman", file);
      k.get("enabled", c.fusion.kalman);
      k.get_number("process_noise", c.fusion.kalman_options.process_noise, 0.0, true);
      k.get_number("measurement_noise", c.fusion.kalman_options.measurement_noise, 0.0, true);
      k.get_number("reset_after", c.fusion.kalman_options.reset_after_s, 0.0, true);
      k.get_number("initial_velocity_std", c.fusion.kalman_options.initial_velocity_std, 0.0, true);
      k.finish();
    }
    f.finish();
  }

  if (r.has("outputs")) {
    const YAML::Node outputs = r.node("outputs");
    if (!outputs.IsSequence()) r.fail(outputs, "outputs", "expected a list of outputs");
    for (std::size_t i = 0; i < outputs.size(); ++i) c.outputs.push_back(parse_output(outputs[i], static_cast<int>(i), file));
    // A MAVLink track restarts when the fusion's Kalman filter would (unless set explicitly).
    for (OutputConfig& o : c.outputs)
      if (std::isnan(o.mavlink.track_gap_s)) o.mavlink.track_gap_s = c.fusion.kalman_options.reset_after_s;
  }
  config_detail::attach_ros2_marker_names(c, root, file);

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
