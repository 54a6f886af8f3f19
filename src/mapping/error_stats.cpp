// Error statistics (mean, min, max, sample std) as in the paper's Tables I and II.
#include "ips/mapping/error_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

namespace ips {

ErrorStats summarize_errors(std::span<const double> errors) {
  if (errors.empty()) throw std::invalid_argument("summarize_errors: no errors");
  ErrorStats s;
  double sum = 0.0;
  s.min = errors[0];
  s.max = errors[0];
  for (double e : errors) {
    sum += e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  const double n = static_cast<double>(errors.size());
  s.mean = sum / n;
  if (errors.size() < 2) {
    s.std = std::numeric_limits<double>::quiet_NaN();
  } else {
    double ss = 0.0;
    for (double e : errors) ss += (e - s.mean) * (e - s.mean);
    s.std = std::sqrt(ss / (n - 1.0));
  }
  return s;
}

CameraErrors compare_points(std::span<const Eigen::Vector3d> predicted, std::span<const Eigen::Vector3d> truth) {
  if (predicted.size() != truth.size() || predicted.empty())
    throw std::invalid_argument("compare_points: sizes differ or empty");
  std::vector<double> e3(predicted.size()), e2(predicted.size());
  for (std::size_t i = 0; i < predicted.size(); ++i) {
    const Eigen::Vector3d d = predicted[i] - truth[i];
    e3[i] = d.norm();
    e2[i] = d.head<2>().norm();
  }
  return CameraErrors{predicted.size(), summarize_errors(e3), summarize_errors(e2)};
}

nlohmann::json errors_to_json(const CameraErrors& errors) {
  auto stats = [](const ErrorStats& s) {
    nlohmann::json j;
    j["mean"] = s.mean;
    j["min"] = s.min;
    j["max"] = s.max;
    j["std"] = std::isfinite(s.std) ? nlohmann::json(s.std) : nlohmann::json(nullptr);
    return j;
  };
  nlohmann::json j;
  j["n"] = errors.n;
  j["err3d"] = stats(errors.err3d);
  j["err2d"] = stats(errors.err2d);
  return j;
}

}  // namespace ips
