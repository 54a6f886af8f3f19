#include "capture/parse_camera.h"

#include <cmath>
#include <type_traits>

#include "core/map_reader.h"

namespace ips::config_detail {

CameraConfig parse_camera(const YAML::Node& n, int index, const std::filesystem::path& base, const std::string& file,
                          bool intrinsics_must_exist) {
  MapReader r(n, "cameras[" + std::to_string(index) + "]", file);
  CameraConfig c;
  c.index = index;
  r.get("name", c.name, true);
  if (c.name.empty()) r.fail(n["name"], r.key("name"), "empty name");
  c.model = c.name;
  r.get("model", c.model);
  c.source = pick<SourceKind>(
      r, "source", {{"v4l2", SourceKind::kV4l2}, {"file", SourceKind::kFile}, {"synthetic", SourceKind::kSynthetic}},
      c.source, true);
  r.get("device", c.v4l2.device, c.source == SourceKind::kV4l2);
  r.get("width", c.v4l2.width);
  r.get("height", c.v4l2.height);
  if (c.v4l2.width <= 0 || c.v4l2.height <= 0) r.fail(n, r.key("width/height"), "must be positive");
  c.v4l2.format = pick<PixelFormat>(r, "pixel_format", {{"MJPEG", PixelFormat::kMjpeg}, {"YUYV", PixelFormat::kYuyv}},
                                    c.v4l2.format, false);
  r.get("buffer_count", c.v4l2.buffer_count);
  if (c.v4l2.buffer_count < 4) r.fail(n["buffer_count"], r.key("buffer_count"), "must be >= 4");
  if (r.has("controls")) {
    MapReader k(r.node("controls"), r.key("controls"), file);
    auto opt = [&k](const std::string& key, auto& field) {
      using T = typename std::remove_reference_t<decltype(field)>::value_type;
      if (!k.has(key)) return;
      T v{};
      k.get(key, v);
      field = v;
    };
    opt("auto_exposure", c.v4l2.controls.auto_exposure);
    opt("exposure", c.v4l2.controls.exposure_s);
    // Seconds, not the V4L2 100-us units: a value like 150 is almost surely a unit mistake.
    if (c.v4l2.controls.exposure_s && !(*c.v4l2.controls.exposure_s > 0 && *c.v4l2.controls.exposure_s <= 1.0))
      k.fail(k.raw()["exposure"], k.key("exposure"), "must be in (0, 1] seconds");
    opt("gain", c.v4l2.controls.gain);
    opt("autofocus", c.v4l2.controls.autofocus);
    opt("power_line_hz", c.v4l2.controls.power_line_hz);
    if (c.v4l2.controls.power_line_hz && *c.v4l2.controls.power_line_hz != 0 && *c.v4l2.controls.power_line_hz != 50 &&
        *c.v4l2.controls.power_line_hz != 60)
      k.fail(k.raw()["power_line_hz"], k.key("power_line_hz"), "must be 50, 60 or 0");
    k.finish();
  }
  std::filesystem::path path;
  r.get_path("path", path, base, c.source == SourceKind::kFile);
  c.file.path = path.string();
  r.get("loop", c.file.loop);
  r.get("preload", c.file.preload);
  r.get_path("scene", c.scene, base, c.source == SourceKind::kSynthetic);
  c.scene_camera = c.name;
  r.get("scene_camera", c.scene_camera);
  r.get_number("fps", c.fps, 0.0, true);
  c.v4l2.fps = c.file.fps = c.fps;
  r.get_path("intrinsics", c.intrinsics, base, c.source != SourceKind::kSynthetic, intrinsics_must_exist);
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
  // cameras[].on_robot belongs to the inside-out stage: the assembly (src/config) reads it.
  if (r.has("on_robot")) (void)r.node("on_robot");
  r.finish();
  return c;
}

}  // namespace ips::config_detail
