// Strict YAML mapping reader shared by the configuration's section parsers (each stage parses
// its own section: src/<stage>/parse_*.cpp; private to the library). Every key must be consumed, or finish() names the
// first unknown one; errors carry "file:line:column: key.path: what" and are ips::InputError.
#pragma once

#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ips/core/accepted_keys.h"
#include "ips/core/error.h"

namespace ips::config_detail {

/// Reads one YAML mapping strictly: every key must be consumed, or finish() names the first
/// unknown one. Errors carry "file:line:column: key.path: what".
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string key_path, const std::string& file)
      : node_(node), path_(std::move(key_path)), file_(file) {
    if (!node_.IsMap()) fail(node_, path_.empty() ? "the document" : path_, "expected a mapping");
    // yaml-cpp keeps duplicate keys silently; a repeated key is almost always a paste error.
    std::set<std::string> keys;
    for (const auto& kv : node_) {
      // A list or mapping as a key (YAML's `? [a]: 1`) has no string form: yaml-cpp would throw
      // its own exception past the file:line message (found by fuzz_scene / fuzz_config).
      if (!kv.first.IsScalar()) fail(kv.first, path_.empty() ? "the document" : path_, "a key must be a plain word");
      const std::string k = kv.first.as<std::string>();
      if (!keys.insert(k).second) fail(kv.first, key(k), "duplicate key");
    }
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
    std::ostringstream s;
    s << file_;
    const YAML::Mark mark = at.Mark();
    if (mark.line >= 0) s << ':' << mark.line + 1 << ':' << mark.column + 1;
    s << ": " << key << ": " << what;
    throw InputError(s.str());
  }

  std::string key(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  bool has(const std::string& k) const { return static_cast<bool>(node_[k]); }

  YAML::Node node(const std::string& k) {
    accept(k);
    return node_[k];
  }

  template <typename T>
  void get(const std::string& k, T& value, bool required = false) {
    accept(k);
    const YAML::Node n = node_[k];
    if (!n) {
      if (required) fail(node_, key(k), "required key is missing");
      return;
    }
    if (!n.IsScalar()) fail(n, key(k), std::string("expected ") + type_name<T>());
    try {
      value = n.as<T>();
    } catch (const YAML::Exception&) {
      fail(n, key(k), std::string("expected ") + type_name<T>() + ", got '" + n.Scalar() + "'");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(value)) fail(n, key(k), "not a finite number");
    }
  }

  /// A number with a lower bound (strict or inclusive).
  void get_number(const std::string& k, double& value, double min, bool strict, bool required = false) {
    get(k, value, required);
    if (has(k) && (strict ? !(value > min) : !(value >= min)))
      fail(node_[k], key(k), "must be " + std::string(strict ? "> " : ">= ") + number(min));
  }

  void get_path(const std::string& k, std::filesystem::path& value, const std::filesystem::path& base, bool required,
                bool must_exist = true) {
    std::string s;
    get(k, s, required);
    if (!has(k)) return;
    if (s.empty()) fail(node_[k], key(k), "empty path");
    std::filesystem::path p(s);
    value = p.is_absolute() ? p : base / p;
    std::error_code ec;
    if (must_exist && !std::filesystem::exists(value, ec)) fail(node_[k], key(k), "no such file: " + value.string());
  }

  void finish() const {
    for (const auto& kv : node_) {
      const std::string k = kv.first.as<std::string>();
      if (!seen_.count(k)) fail(kv.first, key(k), "unknown key");
    }
  }

  const YAML::Node& raw() const { return node_; }

 private:
  /// `k` is a key of this mapping (finish() will not call it unknown).
  void accept(const std::string& k) {
    seen_.insert(k);
    note_accepted_key(key(k));
  }
  template <typename T>
  static const char* type_name() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    if constexpr (std::is_integral_v<T>) return "an integer";
    if constexpr (std::is_floating_point_v<T>) return "a number";
    return "a string";
  }
  static std::string number(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
  }

  YAML::Node node_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> seen_;
};

template <typename Enum>
inline Enum pick(MapReader& r, const std::string& k, const std::vector<std::pair<std::string, Enum>>& choices,
                 Enum value, bool required) {
  std::string s;
  r.get(k, s, required);
  if (!r.has(k)) return value;
  std::string names;
  for (const auto& [name, e] : choices) {
    if (name == s) return e;
    names += (names.empty() ? "" : "|") + name;
  }
  r.fail(r.raw()[k], r.key(k), "unknown value '" + s + "' (" + names + ")");
}

}  // namespace ips::config_detail
