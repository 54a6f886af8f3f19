// Camera -> world mappers: one fitted per camera, chosen by name from a registry.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace ips {

/// Which error a method selection or a cross-validation minimises.
enum class ErrorMetric {
  k3d,  ///< |p_hat - p| in 3-D
  k2d,  ///< |(x_hat, y_hat) - (x, y)| on the floor plane
};

struct FitOptions {
  std::uint64_t seed = 1;                 ///< makes stochastic fits (ann restarts) deterministic
  ErrorMetric metric = ErrorMetric::k3d;  ///< for `auto`
  int folds = 10;                         ///< k for the cross-validation `auto` runs
  /// For `auto`: will the daemon know each marker's height (markers.height or per-ID
  /// heights in its config, the normal case)? Then `plane` competes, scored by its true
  /// error (its z is the known height); otherwise it cannot be used and does not compete.
  bool heights_known = true;
};

/// "3d" / "2d".
std::string metric_name(ErrorMetric metric);
/// Parses "3d" / "2d"; throws ips::InputError naming `where` otherwise.
ErrorMetric parse_metric(const std::string& text, const std::string& where);

/// Maps a marker's camera coordinates (xc, yc, zc) to world coordinates (xw, yw, zw), metres.
class Mapper {
 public:
  static constexpr double kNoHeight = std::numeric_limits<double>::quiet_NaN();

  virtual ~Mapper() = default;

  /// Registry name, e.g. "rt", "rt+pr", "plane".
  virtual std::string method() const = 0;

  /// Fits on paired points (cam[i] -> world[i]). Throws ips::InputError when the data
  /// cannot support the method (too few points, degenerate geometry), naming why.
  virtual void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world,
                   const FitOptions& options) = 0;

  /// Predicts the world position. `known_height` is the marker's world z if known
  /// (kNoHeight otherwise); only mappers whose needs_height() is true use it.
  virtual Eigen::Vector3d predict(const Eigen::Vector3d& cam, double known_height = kNoHeight) const = 0;

  /// True for mappers that need the marker height (the `plane` mapper).
  virtual bool needs_height() const { return false; }

  /// The world ray through camera point `cam` (its direction; the depth is not used):
  /// origin = the camera centre, direction unit length. False for mappers without a camera
  /// pose; rays of two cameras meet at the marker (triangulation, no height needed).
  virtual bool world_ray(const Eigen::Vector3d& /*cam*/, Eigen::Vector3d& /*origin*/,
                         Eigen::Vector3d& /*direction*/) const {
    return false;
  }

  /// The fewest training pairs fit() accepts for this method (checked before fitting,
  /// so a data file with too few rows for a camera is refused with a clear message).
  virtual std::size_t min_points() const = 0;

  /// The fitted parameters, enough for from_json() to reproduce predict() bit for bit.
  virtual nlohmann::json to_json() const = 0;
  /// Restores parameters written by to_json(). Throws ips::InputError on a malformed object.
  virtual void from_json(const nlohmann::json& params) = 0;
};

/// Creates an unfitted mapper by registry name. Throws ips::InputError for an unknown
/// name; the message lists the known ones.
std::unique_ptr<Mapper> make_mapper(const std::string& method);

/// The registry's names, in the order `ips compare` shows them.
std::vector<std::string> mapper_names();

}  // namespace ips
