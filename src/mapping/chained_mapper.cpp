// `rt+X`: a rigid transform first, then X fitted from rt's output to the world.
#include <nlohmann/json.hpp>
#include <vector>

#include "ips/core/error.h"
#include "mapping/json_params.h"
#include "mapping/mappers.h"

namespace ips::mapping {
namespace {

class ChainedMapper final : public Mapper {
 public:
  explicit ChainedMapper(std::unique_ptr<Mapper> inner) : rt_(make_rigid()), inner_(std::move(inner)) {}

  std::string method() const override { return "rt+" + inner_->method(); }
  std::size_t min_points() const override { return std::max(rt_->min_points(), inner_->min_points()); }
  bool needs_height() const override { return inner_->needs_height(); }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world,
           const FitOptions& options) override {
    check_fit_input(*this, cam, world);
    rt_->fit(cam, world, options);
    std::vector<Eigen::Vector3d> moved(cam.size());
    for (std::size_t i = 0; i < cam.size(); ++i) moved[i] = rt_->predict(cam[i]);
    inner_->fit(moved, world, options);
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double known_height) const override {
    return inner_->predict(rt_->predict(cam), known_height);
  }

  nlohmann::json to_json() const override { return {{"rt", rt_->to_json()}, {"inner", inner_->to_json()}}; }

  void from_json(const nlohmann::json& p) override {
    rt_->from_json(member(p, "rt"));
    inner_->from_json(member(p, "inner"));
  }

 private:
  std::unique_ptr<Mapper> rt_;
  std::unique_ptr<Mapper> inner_;
};

}  // namespace

std::unique_ptr<Mapper> make_chained(std::unique_ptr<Mapper> inner) {
  return std::make_unique<ChainedMapper>(std::move(inner));
}

}  // namespace ips::mapping
