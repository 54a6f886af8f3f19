// The scene file's typed reader (src/sim/scene.cpp and scene_ranging.cpp): errors as
// "file:line: key: problem".
#pragma once

#include <cmath>
#include <initializer_list>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ips/core/error.h"
#include "ips/sim/scene.h"

namespace ips::sim {

// Reads typed values from a YAML node and reports errors as "file:line: key: problem".
class SceneReader {
 public:
  explicit SceneReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& key, const std::string& what) const {
    const int line = node.IsDefined() ? node.Mark().line + 1 : 0;
    throw InputError(file_ + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + key + ": " + what);
  }

  double number(const YAML::Node& parent, const std::string& path, const char* key, double def,
                bool required = false) const {
    const YAML::Node n = parent[key];
    if (!n) {
      if (required) fail(parent, path + key, "missing");
      return def;
    }
    return finite(n, path + key);
  }

  /// A scalar that must be a finite number; errors name `key` and the node's line.
  double finite(const YAML::Node& n, const std::string& key) const {
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, "not a number");
    }
    if (!std::isfinite(v)) fail(n, key, "not finite");
    return v;
  }

  /// An optional integer in [lo, hi]. Range first: converting a double outside the target
  /// type's range is undefined (found by fuzz_scene: a 50-digit floor.seed).
  double integer(const YAML::Node& parent, const std::string& path, const char* key, double def, double lo,
                 double hi) const {
    const double v = number(parent, path, key, def);
    if (!(v >= lo && v <= hi) || v != std::floor(v)) {
      std::ostringstream range;
      range << std::fixed << std::setprecision(0) << lo << ".." << hi;
      fail(parent[key], path + key, "must be an integer in " + range.str());
    }
    return v;
  }

  std::vector<double> numbers(const YAML::Node& parent, const std::string& path, const char* key, std::size_t min_n,
                              std::size_t max_n) const {
    const YAML::Node n = parent[key];
    if (!n) fail(parent, path + key, "missing");
    if (!n.IsSequence() || n.size() < min_n || n.size() > max_n) {
      fail(n, path + key,
           "expected a list of " + std::to_string(min_n) +
               (max_n != min_n ? ".." + std::to_string(max_n) : std::string()) + " numbers");
    }
    std::vector<double> out;
    for (const auto& v : n) out.push_back(finite(v, path + key));
    return out;
  }

  std::string text(const YAML::Node& parent, const std::string& path, const char* key, const std::string& def) const {
    const YAML::Node n = parent[key];
    if (!n) return def;
    if (!n.IsScalar()) fail(n, path + key, "expected a string");
    return n.as<std::string>();
  }

  void only_keys(const YAML::Node& map, const std::string& path, std::initializer_list<const char*> keys) const {
    if (!map.IsMap()) fail(map, path.empty() ? "scene" : path, "expected a mapping");
    for (const auto& kv : map) {
      // A list or mapping as a key has no string form (found by fuzz_scene).
      if (!kv.first.IsScalar()) fail(kv.first, path.empty() ? "scene" : path, "a key must be a plain word");
      const auto k = kv.first.as<std::string>();
      bool ok = false;
      for (const char* allowed : keys) ok = ok || k == allowed;
      if (!ok) {
        std::string list;
        for (const char* allowed : keys) list += (list.empty() ? "" : ", ") + std::string(allowed);
        fail(kv.first, path + k, "unknown key (expected one of: " + list + ")");
      }
    }
  }

 private:
  std::string file_;
};

/// The scene's `anchors:`, `nlos_zones:` and `tags:` (src/sim/scene_ranging.cpp), after its
/// markers (a tag names the marker that carries it).
void read_ranging(const SceneReader& r, const YAML::Node& root, Scene& scene);
/// lamps: (src/sim/lamps.cpp).
void read_lamps(const SceneReader& r, const YAML::Node& root, Scene& scene);

}  // namespace ips::sim
