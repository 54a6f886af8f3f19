#include "fusion/parse_fusion.h"

#include "core/map_reader.h"
#include "ips/fusion/fusion.h"

namespace ips::config_detail {

FusionConfig parse_fusion(const YAML::Node& n, const std::string& file) {
  FusionConfig c;
  MapReader f(n, "fusion", file);
  f.get("method", c.method);
  try {
    (void)find_fusion_method(c.method, "fusion.method");
  } catch (const InputError&) {
    std::string known;
    for (const auto& m : fusion_methods()) known += (known.empty() ? "" : "|") + m.name;
    f.fail(f.raw()["method"], "fusion.method", "unknown method '" + c.method + "' (" + known + ")");
  }
  f.get_number("window", c.window_s, 0.0, false);
  f.get_number("velocity_span", c.velocity_span_s, 0.0, false);
  f.get_number("history", c.history_s, 0.0, true);
  if (c.history_s < c.window_s)
    f.fail(f.has("history") ? f.raw()["history"] : f.raw(), "fusion.history", "must be >= fusion.window");
  f.get("single_camera_depth", c.single_camera_depth);
  f.get_number("output_rate", c.output_rate_hz, 0.0, false);
  if (c.output_rate_hz > 1000)
    f.fail(f.raw()["output_rate"], "fusion.output_rate", "must be <= 1000 Hz (0 = one update per camera frame)");
  f.get_number("max_wait", c.max_wait_s, 0.0, true);
  f.get_number("fixed_marker_warn", c.fixed_marker_warn_m, 0.0, true);
  // With another source than the cameras (ranging:): the cameras' weight against it, and the
  // filter that carries an object through where no camera sees it.
  f.get_number("camera_sigma", c.camera_sigma_m, 0.0, true);
  f.get_number("out_of_view_process_noise", c.between_cameras_process_noise, 0.0, true);
  f.get_number("camera_hold", c.camera_hold_s, 0.0, false);
  if (c.camera_hold_s > 10) f.fail(f.raw()["camera_hold"], "fusion.camera_hold", "must be <= 10 s");
  if (f.has("kalman")) {
    MapReader k(f.node("kalman"), "fusion.kalman", file);
    k.get("enabled", c.kalman);
    k.get_number("process_noise", c.kalman_options.process_noise, 0.0, true);
    k.get_number("measurement_noise", c.kalman_options.measurement_noise, 0.0, true);
    k.get_number("reset_after", c.kalman_options.reset_after_s, 0.0, true);
    k.get_number("initial_velocity_std", c.kalman_options.initial_velocity_std, 0.0, true);
    k.finish();
  }
  f.finish();
  return c;
}

}  // namespace ips::config_detail
