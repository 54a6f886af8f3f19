// k-fold and leave-one-out cross-validation of a method on one camera's pairs.
#include "ips/mapping/cross_validation.h"

#include "ips/core/error.h"

namespace ips {

std::vector<int> fold_assignment(std::size_t n, int folds) {
  if (folds < 2) throw InputError("cross-validation needs at least 2 folds, got " + std::to_string(folds));
  const std::size_t k = std::min(static_cast<std::size_t>(folds), n);
  std::vector<int> fold(n);
  for (std::size_t i = 0; i < n; ++i) fold[i] = static_cast<int>(i % k);
  return fold;
}

std::vector<Eigen::Vector3d> cross_validated_predictions(const std::string& method,
                                                         std::span<const Eigen::Vector3d> cam,
                                                         std::span<const Eigen::Vector3d> world, int folds,
                                                         const FitOptions& options) {
  if (cam.size() != world.size() || cam.size() < 2) throw InputError("cross-validation needs at least 2 pairs");
  const int k = folds == 0 ? static_cast<int>(cam.size()) : folds;
  const auto fold = fold_assignment(cam.size(), k);
  const int used = std::min<int>(k, static_cast<int>(cam.size()));
  std::vector<Eigen::Vector3d> predicted(cam.size());
  std::vector<Eigen::Vector3d> tc, tw;
  for (int f = 0; f < used; ++f) {
    tc.clear();
    tw.clear();
    for (std::size_t i = 0; i < cam.size(); ++i)
      if (fold[i] != f) {
        tc.push_back(cam[i]);
        tw.push_back(world[i]);
      }
    auto mapper = make_mapper(method);
    if (tc.size() < mapper->min_points())
      throw InputError("method '" + method + "' needs at least " + std::to_string(mapper->min_points()) +
                       " training pairs per fold, a fold has " + std::to_string(tc.size()));
    mapper->fit(tc, tw, options);
    for (std::size_t i = 0; i < cam.size(); ++i)
      if (fold[i] == f) predicted[i] = mapper->predict(cam[i], world[i].z());
  }
  return predicted;
}

CameraErrors cross_validate(const std::string& method, std::span<const Eigen::Vector3d> cam,
                            std::span<const Eigen::Vector3d> world, int folds, const FitOptions& options) {
  const auto predicted = cross_validated_predictions(method, cam, world, folds, options);
  return compare_points(predicted, world);
}

std::vector<Eigen::Vector3d> predict_points(const Mapper& mapper, std::span<const Eigen::Vector3d> cam,
                                            std::span<const Eigen::Vector3d> world) {
  std::vector<Eigen::Vector3d> predicted(cam.size());
  for (std::size_t i = 0; i < cam.size(); ++i) predicted[i] = mapper.predict(cam[i], world[i].z());
  return predicted;
}

}  // namespace ips
