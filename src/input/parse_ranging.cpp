#include "input/parse_ranging.h"

#include <algorithm>
#include <cmath>

#include "core/map_reader.h"
#include "ips/ranging/multilateration.h"
#include "output/parse_output.h"

namespace ips::config_detail {
namespace {

std::uint32_t read_id(MapReader& r, const YAML::Node& n, const char* what) {
  long long id = -1;
  r.get("id", id, true);
  // Bit 31 of a datagram's reference marks a tag: ids are 0 .. 2^31 - 1.
  if (id < 0 || id > 0x7fffffff) r.fail(n["id"], r.key("id"), std::string(what) + " ids are 0..2147483647");
  return static_cast<std::uint32_t>(id);
}

template <typename Item>
void read_list(MapReader& r, const char* key, const std::string& what, Item&& item) {
  const YAML::Node list = r.node(key);
  if (!list.IsSequence() || list.size() == 0) r.fail(list, r.key(key), "expected a non-empty list of " + what);
  for (std::size_t i = 0; i < list.size(); ++i) item(list[i], r.key(key) + "[" + std::to_string(i) + "]");
}

}  // namespace

RangingConfig parse_ranging(const YAML::Node& node, const std::string& file) {
  RangingConfig c;
  MapReader r(node, "ranging", file);
  RangeInputSettings& in = c.input;
  r.get("address", in.address);
  int port = 0;
  r.get("port", port, true);
  if (port < 1 || port > 65535) r.fail(node["port"], "ranging.port", "must be 1..65535");
  in.port = static_cast<std::uint16_t>(port);
  read_allow_list(r, in.allow);
  r.get("psk", in.psk);
  r.get_number("rate_per_source", in.rate_per_source_hz, 0.0, true);
  r.get_number("reorder_window", in.reorder_window_s, 0.0, false);
  if (in.reorder_window_s > 10) r.fail(node["reorder_window"], "ranging.reorder_window", "must be <= 10 s");
  r.get_number("max_clock_ahead", in.max_clock_ahead_s, 0.0, false);

  r.get("method", c.method);
  const auto& names = range_method_names();
  if (std::find(names.begin(), names.end(), c.method) == names.end()) {
    std::string known;
    for (const auto& n : names) known += (known.empty() ? "" : "|") + n;
    r.fail(node["method"], "ranging.method", "unknown value '" + c.method + "' (" + known + ")");
  }
  if (r.has("height")) {
    double h = 0;
    r.get("height", h);
    c.height = h;
  }
  if (r.has("z_range")) {
    const YAML::Node z = r.node("z_range");
    double lo = 0, hi = 0;
    bool ok = z.IsSequence() && z.size() == 2;
    try {
      if (ok) {
        lo = z[0].as<double>();
        hi = z[1].as<double>();
      }
    } catch (const YAML::Exception&) {
      ok = false;
    }
    if (!ok || !std::isfinite(lo) || !std::isfinite(hi) || !(lo <= hi))
      r.fail(z, "ranging.z_range", "expected [zmin, zmax] in metres with zmin <= zmax");
    if (c.height) r.fail(z, "ranging.z_range", "give either height (known) or z_range, not both");
    c.z_range = std::make_pair(lo, hi);
  }
  r.get_number("sigma", c.sigma_m, 0.0, true);
  if (r.has("track")) {
    const YAML::Node t = r.node("track");
    if (t.IsMap()) {
      MapReader m(t, "ranging.track", file);
      RangeTrackerOptions& o = c.track_options;
      m.get_number("process_noise", o.process_noise, 0.0, true);
      m.get_number("gate", o.gate_sigmas, 0.0, false);
      if (m.has("learn_bias")) {
        std::string learn = "auto";
        m.get("learn_bias", learn);  // YAML's true / false read as their words
        using L = RangeTrackerOptions::BiasLearning;
        if (learn == "auto")
          o.bias_learning = L::kAuto;
        else if (learn == "true")
          o.bias_learning = L::kOn;
        else if (learn == "false")
          o.bias_learning = L::kOff;
        else
          m.fail(t["learn_bias"], "ranging.track.learn_bias", "expected auto, true or false, got '" + learn + "'");
      }
      m.get_number("bias_sigma", o.bias_sigma_m, 0.0, true);
      m.get_number("reorder_window", o.reorder_window_s, 0.0, false);
      m.get("camera_reference", c.track_camera_reference);
      m.get("mutual", c.track_mutual);
      if (o.reorder_window_s > 10) m.fail(t["reorder_window"], "ranging.track.reorder_window", "must be <= 10 s");
      m.finish();
    } else {
      r.get("track", c.track);  // true / false; anything else is refused there, naming the key
    }
  }
  if (r.has("ultrasound")) {
    MapReader u(r.node("ultrasound"), "ranging.ultrasound", file);
    double t = 20.0;
    u.get("temperature", t, /*required=*/true);
    if (t < -40 || t > 60)
      u.fail(u.raw()["temperature"], "ranging.ultrasound.temperature", "must be in [-40, 60] degC");
    c.temperature_c = t;
    u.get_number("assumed_speed", c.assumed_speed_of_sound, 0.0, true);
    if (c.assumed_speed_of_sound < 300 || c.assumed_speed_of_sound > 400)
      u.fail(u.raw()["assumed_speed"], "ranging.ultrasound.assumed_speed", "must be in [300, 400] m/s");
    u.finish();
  }

  read_list(r, "anchors", "anchors ({id, x, y, z})", [&](const YAML::Node& n, const std::string& where) {
    MapReader a(n, where, file);
    const std::uint32_t id = read_id(a, n, "anchor");
    RangingAnchor anchor;
    double x = 0, y = 0, z = 0;
    a.get("x", x, true);
    a.get("y", y, true);
    a.get("z", z, true);
    anchor.position = {x, y, z};
    a.get("bias", anchor.bias_m);
    a.get_number("scale", anchor.scale, 0.5, true);
    if (anchor.scale > 2) a.fail(n["scale"], a.key("scale"), "must be in (0.5, 2]");
    a.get_number("sigma", anchor.sigma_m, 0.0, false);
    a.finish();
    if (!c.anchors.emplace(id, anchor).second)
      a.fail(n["id"], a.key("id"), "anchor " + std::to_string(id) + " is listed twice");
  });
  if (c.anchors.size() < 3)
    r.fail(node["anchors"], "ranging.anchors", "at least 3 anchors (4 without a known height) are needed for a fix");
  read_list(r, "tags", "tags ({id, marker, height} or {id, body, offset})",
            [&](const YAML::Node& n, const std::string& where) {
              MapReader t(n, where, file);
              const std::uint32_t id = read_id(t, n, "tag");
              RangingTag tag;
              t.get("marker", tag.marker);
              t.get("body", tag.body);
              t.get("height", tag.height);
              if (t.has("height") && t.has("body"))
                t.fail(n["height"], t.key("height"),
                       "on a body the tag's place is its `offset` [x, y, z] in the body's frame");
              if (t.has("marker") == t.has("body"))
                t.fail(
                    n, where,
                    "give either `marker` (the marker id the tag's fixes are published as) or `body` (a body's name)");
              if (t.has("marker") && tag.marker < 0)
                t.fail(n["marker"], t.key("marker"), "a marker id (>= 0) the tag's fixes are published as");
              if (t.has("offset")) {
                const YAML::Node o = t.node("offset");
                if (tag.marker >= 0)
                  t.fail(o, t.key("offset"),
                         "an offset places a tag on a body (`body`); on a marker, `height` above its centre");
                bool ok = o.IsSequence() && o.size() == 3;
                for (std::size_t k = 0; ok && k < 3; ++k) {
                  try {
                    tag.offset[static_cast<Eigen::Index>(k)] = o[k].as<double>();
                    ok = std::isfinite(tag.offset[static_cast<Eigen::Index>(k)]);
                  } catch (const YAML::Exception&) {
                    ok = false;
                  }
                }
                if (!ok) t.fail(o, t.key("offset"), "expected [x, y, z]: the tag in the body's frame, metres");
              }
              t.finish();
              if (!c.tags.emplace(id, tag).second)
                t.fail(n["id"], t.key("id"), "tag " + std::to_string(id) + " is listed twice");
            });
  r.finish();
  for (const auto& [id, a] : c.anchors) in.anchors.insert(id);
  for (const auto& [id, t] : c.tags) in.tags.insert(id);
  return c;
}

}  // namespace ips::config_detail
