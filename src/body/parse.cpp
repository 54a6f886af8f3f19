// Reads body definitions from YAML (the daemon's config `bodies:` and the simulator's scene
// `bodies:` share it); strict: unknown keys, bad sizes, overlapping faces, an id in two bodies
// are errors naming the key.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <yaml-cpp/yaml.h>

#include "ips/body/body.h"
#include "ips/core/accepted_keys.h"
#include "ips/output/packet_codec.h"

namespace ips {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Ctx {
  const BodyFail& fail;
  [[noreturn]] void error(const YAML::Node& at, const std::string& key, const std::string& what) const {
    fail(at, key, what);
    throw std::logic_error("BodyFail returned");  // the callback must throw
  }
  void only(const YAML::Node& n, const std::string& key, const std::vector<std::string>& keys) const {
    if (!n.IsMap()) error(n, key, "expected a mapping");
    for (const auto& k : keys) note_accepted_key(key + "." + k);
    for (const auto& kv : n) {
      const std::string k = kv.first.as<std::string>();
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        std::string list;
        for (const auto& a : keys) list += (list.empty() ? "" : ", ") + a;
        error(kv.first, key + "." + k, "unknown key (expected one of: " + list + ")");
      }
    }
  }
  double number(const YAML::Node& n, const std::string& key) const {
    double v = 0;
    if (!n.IsScalar()) error(n, key, "expected a number");
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      error(n, key, "expected a number, got '" + n.Scalar() + "'");
    }
    if (!std::isfinite(v)) error(n, key, "not a finite number");
    return v;
  }
  double positive(const YAML::Node& parent, const std::string& key, const char* k, double def) const {
    const YAML::Node n = parent[k];
    if (!n) {
      if (def > 0) return def;
      error(parent, key + "." + k, "required key is missing");
    }
    const double v = number(n, key + "." + k);
    if (!(v > 0)) error(n, key + "." + k, "must be > 0 (metres)");
    return v;
  }
  int id(const YAML::Node& parent, const std::string& key) const {
    const YAML::Node n = parent["id"];
    if (!n) error(parent, key + ".id", "required key is missing");
    const double v = number(n, key + ".id");
    if (v < 0 || v != std::floor(v) || v > 1e6) error(n, key + ".id", "must be a non-negative integer");
    return static_cast<int>(v);
  }
  Eigen::Vector3d vec(const YAML::Node& n, const std::string& key, std::size_t min_n, double z_default) const {
    if (!n.IsSequence() || n.size() < min_n || n.size() > 3)
      error(n, key, min_n == 3 ? "expected [x, y, z] (metres)" : "expected [x, y] or [x, y, z] (metres)");
    Eigen::Vector3d v(0, 0, z_default);
    for (std::size_t i = 0; i < n.size(); ++i) v[static_cast<Eigen::Index>(i)] = number(n[i], key);
    return v;
  }
};

}  // namespace

BodyDef parse_body(const YAML::Node& node, const std::string& key, const std::vector<std::string>& extra_keys,
                   const BodyFail& fail) {
  const Ctx c{fail};
  std::vector<std::string> keys{"name", "ground", "edge", "cube", "flat", "markers"};
  keys.insert(keys.end(), extra_keys.begin(), extra_keys.end());
  c.only(node, key, keys);
  BodyDef b;
  const YAML::Node name = node["name"];
  if (!name || !name.IsScalar() || name.Scalar().empty())
    c.error(name ? name : node, key + ".name", "required: the body's name");
  b.name = name.Scalar();
  if (!valid_body_name(b.name))  // the stream carries it in 32 NUL-padded bytes (include/ips/output/wire.h)
    c.error(name, key + ".name", "body name must be 1-31 bytes of UTF-8 without NUL: '" + b.name + "'");
  if (const YAML::Node g = node["ground"]) {
    try {
      b.ground = g.as<bool>();
    } catch (const YAML::Exception&) {
      c.error(g, key + ".ground", "expected true or false");
    }
  }
  const double body_edge = node["edge"] ? c.positive(node, key, "edge", 0) : 0.0;

  // Which YAML node and key each marker came from, for errors about pairs of markers.
  std::vector<std::pair<YAML::Node, std::string>> origin;
  if (const YAML::Node cube = node["cube"]) {
    const std::string k = key + ".cube";
    c.only(cube, k, {"id", "edge", "size", "height"});
    const int id = c.id(cube, k);
    const double edge = c.positive(cube, k, "edge", body_edge);
    const double size = c.positive(cube, k, "size", 0);
    if (edge > size)
      c.error(cube["edge"] ? cube["edge"] : cube, k + ".edge", "the marker is larger than the cube face (size)");
    double height = 0;
    if (cube["height"]) {
      height = c.number(cube["height"], k + ".height");
      if (height < 0) c.error(cube["height"], k + ".height", "must be >= 0 (the cube's bottom above the body origin)");
    }
    for (auto& m : cube_markers(id, edge, size, height)) {
      b.markers.push_back(m);
      origin.emplace_back(cube, k);
    }
  }
  if (const YAML::Node flat = node["flat"]) {
    if (!flat.IsSequence() || flat.size() == 0) c.error(flat, key + ".flat", "expected a list of {id, offset}");
    for (std::size_t i = 0; i < flat.size(); ++i) {
      const std::string k = key + ".flat[" + std::to_string(i) + "]";
      c.only(flat[i], k, {"id", "offset", "edge", "yaw_deg"});
      const int id = c.id(flat[i], k);
      const double edge = c.positive(flat[i], k, "edge", body_edge);
      if (!flat[i]["offset"]) c.error(flat[i], k + ".offset", "required key is missing");
      const Eigen::Vector3d off = c.vec(flat[i]["offset"], k + ".offset", 2, 0.0);
      const double yaw = flat[i]["yaw_deg"] ? c.number(flat[i]["yaw_deg"], k + ".yaw_deg") * kDeg : 0.0;
      b.markers.push_back(flat_marker(id, edge, off, yaw));
      origin.emplace_back(flat[i], k);
    }
  }
  if (const YAML::Node ms = node["markers"]) {
    if (!ms.IsSequence() || ms.size() == 0) c.error(ms, key + ".markers", "expected a list of markers");
    for (std::size_t i = 0; i < ms.size(); ++i) {
      const std::string k = key + ".markers[" + std::to_string(i) + "]";
      c.only(ms[i], k, {"id", "edge", "plate", "position", "normal", "roll_deg"});
      BodyMarker m;
      m.id = c.id(ms[i], k);
      m.edge = c.positive(ms[i], k, "edge", body_edge);
      m.plate = ms[i]["plate"] ? c.positive(ms[i], k, "plate", 0) : m.edge;
      if (m.plate < m.edge) c.error(ms[i]["plate"], k + ".plate", "smaller than the marker's edge");
      if (!ms[i]["position"]) c.error(ms[i], k + ".position", "required key is missing");
      m.position = c.vec(ms[i]["position"], k + ".position", 3, 0.0);
      Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
      if (ms[i]["normal"]) {
        n = c.vec(ms[i]["normal"], k + ".normal", 3, 0.0);
        if (!(n.norm() > 1e-9)) c.error(ms[i]["normal"], k + ".normal", "must not be zero");
      }
      const double roll = ms[i]["roll_deg"] ? c.number(ms[i]["roll_deg"], k + ".roll_deg") * kDeg : 0.0;
      m.axes = face_axes(n, roll);
      b.markers.push_back(m);
      origin.emplace_back(ms[i], k);
    }
  }
  if (b.markers.empty()) c.error(node, key, "body '" + b.name + "' has no markers (give cube, flat or markers)");
  for (std::size_t i = 0; i < b.markers.size(); ++i) {
    for (std::size_t j = i + 1; j < b.markers.size(); ++j) {
      const std::string why = marker_overlap(b.markers[i], b.markers[j]);
      if (!why.empty()) {
        c.error(origin[j].first, origin[j].second,
                why + " with " + (origin[i].second == origin[j].second ? "another face of it" : origin[i].second));
      }
    }
  }
  return b;
}

void check_bodies(const std::vector<BodyDef>& bodies, const std::vector<YAML::Node>& nodes, const std::string& list_key,
                  const BodyFail& fail) {
  const Ctx c{fail};
  std::map<int, std::size_t> owner;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const std::string k = list_key + "[" + std::to_string(i) + "]";
    for (std::size_t j = 0; j < i; ++j) {
      if (bodies[j].name == bodies[i].name)
        c.error(nodes[i]["name"], k + ".name", "duplicate body name '" + bodies[i].name + "'");
    }
    for (const auto& m : bodies[i].markers) {
      const auto [it, inserted] = owner.emplace(m.id, i);
      if (!inserted && it->second != i) {
        c.error(nodes[i], k,
                "marker id " + std::to_string(m.id) + " is already used by body '" + bodies[it->second].name + "' (" +
                    list_key + "[" + std::to_string(it->second) + "])");
      }
    }
  }
}

}  // namespace ips
