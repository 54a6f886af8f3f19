// The robots of config/scenes/bodies_lab.yaml (a marker cube "turtle", a two-marker robot
// "long") driving opposite each other round the published lab at 0.5 m/s, with one plain
// marker 3: the scene and the daemon's matching `bodies:` section, for the suites that run the
// real ipsd with bodies.
#pragma once

#include <string>

#include "published_scene.h"

namespace ips::test {

inline const char* kBodiesLabCube = "  - name: turtle\n    cube: {id: 5, edge: 0.075, size: 0.10, height: 0.30}\n";
inline const char* kBodiesLabLong =
    "  - name: long\n    edge: 0.10\n    flat: [{id: 7, offset: [0.2, 0, 0.25]}, {id: 8, offset: [-0.2, 0, 0.25]}]\n";

/// The simulator's scene (bodies with trajectories).
inline std::string bodies_lab_scene() {
  return published_scene_with(
      std::string("markers:\n  - {id: 3, length: 0.15, height: 0.10, x: 1.2, y: 2.0, yaw_deg: 20}\nbodies:\n") +
      kBodiesLabCube + "    trajectory: {type: circle, center: [2.44, 2.44], radius: 1.95, speed: 0.5}\n" +
      kBodiesLabLong +
      "    trajectory: {type: circle, center: [2.44, 2.44], radius: 1.95, speed: 0.5, start_deg: 180}\n");
}

/// The daemon configuration's markers and bodies for that scene.
inline std::string bodies_lab_daemon_sections() {
  return "markers:\n  ids:\n    3: {height: 0.10, edge_length: 0.15}\nbodies:\n" + std::string(kBodiesLabCube) +
         kBodiesLabLong;
}

}  // namespace ips::test
