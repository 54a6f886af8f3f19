// Reading and writing mapper parameters as JSON, with validation that names the key.
// Doubles are written by nlohmann::json in shortest round-trip form and read back with
// strtod, so every finite double survives save -> load bit for bit.
#pragma once

#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace ips::mapping {

nlohmann::json to_json_array(const Eigen::VectorXd& v);
/// Row-major: an array of rows.
nlohmann::json to_json_rows(const Eigen::MatrixXd& m);

/// The object member `key` (must be an object). Throws ips::InputError naming the key.
const nlohmann::json& member(const nlohmann::json& obj, const std::string& key);
/// A finite number.
double get_number(const nlohmann::json& obj, const std::string& key);
/// An integer in [lo, hi].
int get_int(const nlohmann::json& obj, const std::string& key, int lo, int hi);
/// A string.
std::string get_string(const nlohmann::json& obj, const std::string& key);
/// An array of finite numbers; `size` < 0 accepts any non-empty length.
Eigen::VectorXd get_vector(const nlohmann::json& obj, const std::string& key, Eigen::Index size);
/// An array of `rows` arrays of `cols` finite numbers (rows < 0: any non-zero count).
Eigen::MatrixXd get_rows(const nlohmann::json& obj, const std::string& key, Eigen::Index rows, Eigen::Index cols);

}  // namespace ips::mapping
