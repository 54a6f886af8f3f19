// The `plane` model of every camera of a scene, fitted on exact simulated pairs (what
// tools/demo.sh does with `ips sim collect` + `ips fit`, but from the exact projected corners
// through the depth formula rather than from rendered images, so that suites stay fast under
// the sanitizers; detection noise is in the daemon's runs).
#pragma once

#include <filesystem>
#include <memory>
#include <random>
#include <vector>

#include "ips/mapping/mapper.h"
#include "ips/mapping/model_file.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"

namespace ips::test {

// One camera's `plane` model from 30 exact pairs at random floor poses drawn from `rng`.
inline std::unique_ptr<Mapper> fit_plane_on_exact_pairs(const sim::CameraRenderer& renderer, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  sim::SceneMarker marker;
  marker.id = 0;
  marker.length = 0.20;
  std::vector<Eigen::Vector3d> cam, world;
  while (cam.size() < 30) {
    const sim::MarkerPose pose{0.2 + 4.48 * u(rng), 0.2 + 4.48 * u(rng), 0.2 * u(rng), 6.283 * u(rng)};
    const sim::MarkerTruth truth = renderer.truth_of(marker, pose);
    if (!truth.visible) continue;
    cam.push_back(truth.formula.p_cam);
    world.emplace_back(pose.x, pose.y, pose.z);
  }
  auto mapper = make_mapper("plane");
  mapper->fit(cam, world, FitOptions{});
  return mapper;
}

/// Every overhead camera's (a camera looking up has no floor to fit on).
inline void write_plane_model(const std::filesystem::path& scene_file, const std::filesystem::path& out) {
  const auto scene_model = sim::Scene::load(scene_file);
  ModelSet models;
  std::mt19937_64 rng(7);
  for (std::size_t c = 0; c < scene_model.cameras.size(); ++c) {
    if (scene_model.cameras[c].looks_up) continue;  // a robot's camera: it maps through the ceiling map
    CameraModelEntry entry;
    entry.mapper = fit_plane_on_exact_pairs(sim::CameraRenderer(scene_model, c), rng);
    entry.training = {{"n", 30}, {"source", "ipsd_test: exact simulated pairs"}};
    models.cameras[scene_model.cameras[c].name] = std::move(entry);
  }
  save_model_file(models, out);
}

}  // namespace ips::test
