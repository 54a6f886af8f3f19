// `auto`: per camera, the method with the least k-fold cross-validated mean error on the
// training pairs (metric 3d or 2d), refitted on all pairs. The CV table is kept with the
// parameters so the model file shows why the method was chosen. Candidates: every registered
// method except auto itself; plane only when the marker heights will be known in the daemon
// (FitOptions::heights_known): it is given the height instead of estimating it, so its
// cross-validated 3-D error is its true error there (z exact, the 2-D error is all of it).
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "ips/mapping/cross_validation.h"
#include "mapping/json_params.h"
#include "mapping/mappers.h"

namespace ips::mapping {
namespace {

class AutoMapper final : public Mapper {
 public:
  std::string method() const override { return "auto"; }
  std::size_t min_points() const override { return 4; }
  bool needs_height() const override { return chosen_ && chosen_->needs_height(); }
  bool world_ray(const Eigen::Vector3d& cam, Eigen::Vector3d& origin, Eigen::Vector3d& direction) const override {
    return chosen_ && chosen_->world_ray(cam, origin, direction);
  }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world,
           const FitOptions& options) override {
    check_fit_input(*this, cam, world);
    const int folds = std::min<int>(options.folds, static_cast<int>(cam.size()));
    if (folds < 2) throw InputError("auto: needs at least 2 folds");
    // Smallest training fold in k-fold: n - ceil(n / k).
    const std::size_t train_size =
        cam.size() - (cam.size() + static_cast<std::size_t>(folds) - 1) / static_cast<std::size_t>(folds);
    nlohmann::json table = nlohmann::json::object();
    std::string best_name;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& name : mapper_names()) {
      if (name == "auto") continue;
      // plane needs the height at run time: without it the daemon cannot use it at all.
      if (name == "plane" && !options.heights_known) continue;
      if (make_mapper(name)->min_points() > train_size) continue;  // too few pairs for it
      CameraErrors e;
      try {
        e = cross_validate(name, cam, world, folds, options);
      } catch (const InputError& err) {
        table[name] = {{"error", err.what()}};
        continue;
      }
      table[name] = {{"err3d_mean", e.err3d.mean}, {"err2d_mean", e.err2d.mean}};
      const double score = options.metric == ErrorMetric::k2d ? e.err2d.mean : e.err3d.mean;
      if (std::isfinite(score) && score < best) {
        best = score;
        best_name = name;
      }
    }
    if (best_name.empty()) throw InputError("auto: no method could be cross-validated on these pairs");
    auto chosen = make_mapper(best_name);
    chosen->fit(cam, world, options);
    chosen_ = std::move(chosen);
    metric_ = options.metric;
    heights_known_ = options.heights_known;
    folds_ = folds;
    table_ = table;
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double known_height) const override {
    return chosen_->predict(cam, known_height);
  }

  nlohmann::json to_json() const override {
    return {{"chosen", chosen_->method()},     {"metric", metric_name(metric_)},
            {"heights_known", heights_known_}, {"folds", folds_},
            {"cv_mean_error", table_},         {"model", chosen_->to_json()}};
  }

  void from_json(const nlohmann::json& p) override {
    const std::string name = get_string(p, "chosen");
    if (name == "auto") throw InputError("parameter 'chosen': cannot be 'auto'");
    auto chosen = make_mapper(name);
    chosen->from_json(member(p, "model"));
    metric_ = parse_metric(get_string(p, "metric"), "parameter 'metric'");
    folds_ = get_int(p, "folds", 2, 1000000);
    // Files written before the key existed: plane competed only when heights were known.
    heights_known_ = name == "plane";
    if (p.contains("heights_known")) {
      if (!p["heights_known"].is_boolean()) throw InputError("parameter 'heights_known': expected true or false");
      heights_known_ = p["heights_known"].get<bool>();
    }
    table_ = member(p, "cv_mean_error");
    chosen_ = std::move(chosen);
  }

 private:
  std::unique_ptr<Mapper> chosen_ = make_rigid();
  ErrorMetric metric_ = ErrorMetric::k3d;
  bool heights_known_ = true;
  int folds_ = 10;
  nlohmann::json table_ = nlohmann::json::object();
};

}  // namespace

std::unique_ptr<Mapper> make_auto() { return std::make_unique<AutoMapper>(); }

}  // namespace ips::mapping
