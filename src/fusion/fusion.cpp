#include "ips/fusion/fusion.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "ips/core/error.h"

namespace ips {
namespace {

double weight_one(const WorldObservation&) { return 1.0; }
double weight_area(const WorldObservation& o) { return o.area_px; }
// Inverse variance with variance 1/area^2: a marker twice as large in the image (closer,
// less oblique) is treated as having half the position noise.
double weight_gauss(const WorldObservation& o) { return o.area_px * o.area_px; }

double median_of(std::vector<double> v) {
  const std::size_t n = v.size();
  std::sort(v.begin(), v.end());
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

const std::vector<FusionMethod>& fusion_methods() {
  static const std::vector<FusionMethod> methods = {
      {"mean", "plain mean of the cameras' estimates", &weight_one},
      {"area", "mean weighted by the marker's pixel area", &weight_area},
      {"gauss", "inverse-variance mean, variance 1/area^2 (weight area^2)", &weight_gauss},
      {"median", "per-axis median (robust to one camera's outlier)", nullptr},
  };
  return methods;
}

const FusionMethod& find_fusion_method(const std::string& name, const std::string& where) {
  std::string known;
  for (const auto& m : fusion_methods()) {
    if (m.name == name) return m;
    known += (known.empty() ? "" : ", ") + m.name;
  }
  throw InputError(where + ": unknown fusion method '" + name + "' (known: " + known + ")");
}

FusedMarker fuse_marker(std::span<const WorldObservation> obs, const FusionMethod& method) {
  FusedMarker f;
  if (obs.empty()) return f;
  f.id = obs.front().id;
  std::vector<double> w(obs.size(), 1.0);
  if (method.weight) {
    for (std::size_t i = 0; i < obs.size(); ++i) w[i] = std::max(0.0, method.weight(obs[i]));
  }
  double wsum = 0.0;
  for (double x : w) wsum += x;
  if (!(wsum > 0.0) || !std::isfinite(wsum)) {  // all-zero areas: fall back to equal weights
    std::fill(w.begin(), w.end(), 1.0);
    wsum = static_cast<double>(obs.size());
  }

  double sin_sum = 0.0, cos_sum = 0.0, dt_sum = 0.0, yaw_weight = 0.0;
  const std::int64_t t0 = obs.front().t_mono_ns;
  const std::int64_t r0 = obs.front().t_real_ns;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const double wi = w[i] / wsum;
    p += wi * obs[i].p_world;
    if (obs[i].has_yaw) {
      sin_sum += wi * std::sin(obs[i].yaw);
      cos_sum += wi * std::cos(obs[i].yaw);
      yaw_weight += wi;
    }
    dt_sum += wi * static_cast<double>(obs[i].t_mono_ns - t0);
    f.sources |= source_bit(obs[i].source);
    if (obs[i].source == ObservationSource::kCamera && obs[i].camera_index >= 0 && obs[i].camera_index < 32)
      f.camera_mask |= 1u << obs[i].camera_index;
    f.quality += obs[i].area_px;
  }
  if (!method.weight) {  // median
    std::vector<double> xs, ys, zs;
    for (const auto& o : obs) {
      xs.push_back(o.p_world.x());
      ys.push_back(o.p_world.y());
      zs.push_back(o.p_world.z());
    }
    p = {median_of(xs), median_of(ys), median_of(zs)};
  }
  f.p_world = p;
  f.has_yaw = yaw_weight > 0.0;
  f.yaw = f.has_yaw ? std::atan2(sin_sum, cos_sum) : 0.0;
  const auto dt = static_cast<std::int64_t>(std::llround(dt_sum));
  f.t_mono_ns = t0 + dt;
  f.t_real_ns = r0 + dt;
  for (const auto& o : obs) f.spread = std::max(f.spread, (o.p_world - p).norm());
  return f;
}

std::vector<FusedMarker> fuse(std::span<const WorldObservation> observations, const FusionMethod& method) {
  std::map<int, std::vector<WorldObservation>> by_id;
  for (const auto& o : observations) by_id[o.id].push_back(o);
  std::vector<FusedMarker> out;
  out.reserve(by_id.size());
  for (const auto& [id, group] : by_id) out.push_back(fuse_marker(group, method));
  return out;
}

}  // namespace ips
