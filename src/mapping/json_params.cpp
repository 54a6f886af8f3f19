#include "mapping/json_params.h"

#include <cmath>

#include "ips/core/error.h"

namespace ips::mapping {
namespace {

double finite_number(const nlohmann::json& v, const std::string& what) {
  if (!v.is_number()) throw InputError("parameter '" + what + "': expected a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw InputError("parameter '" + what + "': not a finite number");
  return d;
}

}  // namespace

nlohmann::json to_json_array(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

nlohmann::json to_json_rows(const Eigen::MatrixXd& m) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) a.push_back(to_json_array(m.row(r).transpose()));
  return a;
}

const nlohmann::json& member(const nlohmann::json& obj, const std::string& key) {
  if (!obj.is_object()) throw InputError("parameters: expected an object around '" + key + "'");
  const auto it = obj.find(key);
  if (it == obj.end()) throw InputError("parameter '" + key + "' is missing");
  return *it;
}

double get_number(const nlohmann::json& obj, const std::string& key) { return finite_number(member(obj, key), key); }

int get_int(const nlohmann::json& obj, const std::string& key, int lo, int hi) {
  const auto& v = member(obj, key);
  if (!v.is_number_integer()) throw InputError("parameter '" + key + "': expected an integer");
  const auto i = v.get<long long>();
  if (i < lo || i > hi)
    throw InputError("parameter '" + key + "': " + std::to_string(i) + " is outside [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "]");
  return static_cast<int>(i);
}

std::string get_string(const nlohmann::json& obj, const std::string& key) {
  const auto& v = member(obj, key);
  if (!v.is_string()) throw InputError("parameter '" + key + "': expected a string");
  return v.get<std::string>();
}

Eigen::VectorXd get_vector(const nlohmann::json& obj, const std::string& key, Eigen::Index size) {
  const auto& v = member(obj, key);
  if (!v.is_array() || v.empty() || (size >= 0 && static_cast<Eigen::Index>(v.size()) != size))
    throw InputError("parameter '" + key + "': expected an array of " +
                     (size >= 0 ? std::to_string(size) : std::string("some")) + " numbers");
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i)
    out[static_cast<Eigen::Index>(i)] = finite_number(v[i], key + "[" + std::to_string(i) + "]");
  return out;
}

Eigen::MatrixXd get_rows(const nlohmann::json& obj, const std::string& key, Eigen::Index rows, Eigen::Index cols) {
  const auto& v = member(obj, key);
  if (!v.is_array() || v.empty() || (rows >= 0 && static_cast<Eigen::Index>(v.size()) != rows))
    throw InputError("parameter '" + key + "': expected an array of " +
                     (rows >= 0 ? std::to_string(rows) : std::string("some")) + " rows");
  Eigen::MatrixXd out(static_cast<Eigen::Index>(v.size()), cols);
  for (std::size_t r = 0; r < v.size(); ++r) {
    const auto& row = v[r];
    const std::string name = key + "[" + std::to_string(r) + "]";
    if (!row.is_array() || static_cast<Eigen::Index>(row.size()) != cols)
      throw InputError("parameter '" + name + "': expected " + std::to_string(cols) + " numbers");
    for (std::size_t c = 0; c < row.size(); ++c)
      out(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) =
          finite_number(row[c], name + "[" + std::to_string(c) + "]");
  }
  return out;
}

}  // namespace ips::mapping
