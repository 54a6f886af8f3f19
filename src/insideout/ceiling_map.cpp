#include "ips/insideout/ceiling_map.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/detect/detector.h"

namespace ips {
namespace {

constexpr const char* kCeilingMapFormat = "ips-ceiling-map";
constexpr int kCeilingMapVersion = 1;
// Corners of the black square in marker units (x right, y up as printed), ArUco order.
constexpr double kCeilingCorners[4][2] = {{-0.5, 0.5}, {0.5, 0.5}, {0.5, -0.5}, {-0.5, -0.5}};

double map_number(const nlohmann::json& m, const char* key, const std::string& where, bool required, double fallback) {
  if (!m.contains(key)) {
    if (required) throw InputError(where + "." + key + ": missing");
    return fallback;
  }
  const auto& v = m[key];
  if (!v.is_number()) throw InputError(where + "." + key + ": expected a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InputError(where + "." + key + ": not a finite number");
  return d;
}

}  // namespace

Eigen::Matrix3d CeilingMarker::axes() const {
  const double c = std::cos(yaw), s = std::sin(yaw);
  Eigen::Matrix3d a;
  // x at heading yaw; normal down; y = normal x x (right-handed, as printed seen from below).
  a.col(0) = Eigen::Vector3d(c, s, 0);
  a.col(2) = Eigen::Vector3d(0, 0, -1);
  a.col(1) = a.col(2).cross(a.col(0));
  return a;
}

std::array<Eigen::Vector3d, 4> CeilingMarker::corners() const {
  const Eigen::Matrix3d a = axes();
  std::array<Eigen::Vector3d, 4> out;
  for (int i = 0; i < 4; ++i)
    out[i] = centre + length * (kCeilingCorners[i][0] * a.col(0) + kCeilingCorners[i][1] * a.col(1));
  return out;
}

const CeilingMarker* CeilingMap::find(int id) const {
  for (const auto& m : markers) {
    if (m.id == id) return &m;
  }
  return nullptr;
}

CeilingMap CeilingMap::parse(const std::string& text, const std::string& name) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // a syntax error, or a number out of range (1e999)
    throw InputError(name + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw InputError(name + ": expected a JSON object");
  if (!j.contains("format") || j["format"] != kCeilingMapFormat) {
    throw InputError(name + ": format: expected \"" + kCeilingMapFormat +
                     "\" (a map written by ips map or ips sim drive)");
  }
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<int>() != kCeilingMapVersion) {
    throw InputError(name + ": version: this ips reads version " + std::to_string(kCeilingMapVersion));
  }
  CeilingMap map;
  if (j.contains("dictionary")) {
    if (!j["dictionary"].is_string()) throw InputError(name + ": dictionary: expected a string");
    map.dictionary = j["dictionary"].get<std::string>();
    try {
      dictionary_id(map.dictionary);
    } catch (const InputError& e) {
      throw InputError(name + ": dictionary: " + e.what());
    }
  }
  if (!j.contains("markers") || !j["markers"].is_array() || j["markers"].empty()) {
    throw InputError(name + ": markers: expected a non-empty list");
  }
  std::set<int> ids;
  for (std::size_t i = 0; i < j["markers"].size(); ++i) {
    const auto& m = j["markers"][i];
    const std::string where = name + ": markers[" + std::to_string(i) + "]";
    if (!m.is_object()) throw InputError(where + ": expected an object");
    CeilingMarker mk;
    const double id = map_number(m, "id", where, true, 0);
    if (id < 0 || id != std::floor(id) || id > 1e6) throw InputError(where + ".id: must be a non-negative integer");
    mk.id = static_cast<int>(id);
    if (!ids.insert(mk.id).second) throw InputError(where + ".id: duplicate marker id " + std::to_string(mk.id));
    mk.centre = {map_number(m, "x", where, true, 0), map_number(m, "y", where, true, 0),
                 map_number(m, "z", where, true, 0)};
    mk.yaw = map_number(m, "yaw", where, true, 0);
    mk.length = map_number(m, "length", where, true, 0);
    if (!(mk.length > 0.005 && mk.length < 5)) throw InputError(where + ".length: must be 0.005..5 m");
    if (m.contains("sigma")) {
      const auto& s = m["sigma"];
      if (!s.is_array() || s.size() != 4) throw InputError(where + ".sigma: expected [sx, sy, sz, syaw]");
      Eigen::Vector4d v;
      for (int k = 0; k < 4; ++k) {
        if (!s[k].is_number() || !std::isfinite(s[k].get<double>()) || s[k].get<double>() < 0) {
          throw InputError(where + ".sigma: expected four finite numbers >= 0");
        }
        v[k] = s[k].get<double>();
      }
      mk.sigma = v;
    }
    map.markers.push_back(mk);
  }
  return map;
}

CeilingMap CeilingMap::load(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open the ceiling map");
  std::stringstream s;
  s << in.rdbuf();
  return parse(s.str(), path.string());
}

std::string CeilingMap::to_json() const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& m : markers) {
    nlohmann::json e{{"id", m.id},        {"x", m.centre.x()}, {"y", m.centre.y()},
                     {"z", m.centre.z()}, {"yaw", m.yaw},      {"length", m.length}};
    if (m.sigma) e["sigma"] = {(*m.sigma)[0], (*m.sigma)[1], (*m.sigma)[2], (*m.sigma)[3]};
    list.push_back(e);
  }
  return nlohmann::json{{"format", kCeilingMapFormat},
                        {"version", kCeilingMapVersion},
                        {"dictionary", dictionary},
                        {"markers", list}}
             .dump(1) +
         "\n";
}

}  // namespace ips
