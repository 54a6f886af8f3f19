// One placement of an `ips collect` session: every camera read for --frames frames after the
// Enter key, each camera's verdict printed, and the placement refused (the marker moved or no
// camera saw it steadily) or its camera coordinates kept; a position typed as two tape
// distances put on its side of the line A->B. Also the session's text helpers.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "collect_cameras.h"
#include "ips/collect/collect.h"

namespace ips::cli {
namespace cmd_collect {  // named, not anonymous: unique in a unity build

// Writes `text` to stdout and flushes it (the session is interactive).
void say(const std::string& text);

// "x 1.200  y 0.850  z 0.000 m"
std::string xyz(const Eigen::Vector3d& p);

// How each placement is read and judged (from the command line).
struct ReadOptions {
  int marker = -1;
  int frames = 30;
  collect::SteadyOptions steady;
};

// Reads every camera in `cams` for `options.frames` frames captured after `entered_ns`
// (CLOCK_MONOTONIC), all at once, and prints one line per camera. Returns false, after
// printing why, when the placement is refused: the marker moved, or no camera saw it
// steadily. Otherwise adds each camera that saw it steadily to `placement.cameras`.
bool read_placement(std::vector<CameraRun>& cams, const ReadOptions& options, std::int64_t entered_ns,
                    collect::Placement& placement);

// The two floor positions at distances `e.d_a` from `ref_a` and `e.d_b` from `ref_b`. Returns
// false, after printing why, when there are none.
bool distance_candidates(const Eigen::Vector2d& ref_a, const Eigen::Vector2d& ref_b, const collect::Entry& e,
                         std::array<Eigen::Vector2d, 2>& candidates);

// The world position of a distances entry `e`: the candidate on the side typed, else on the
// side the cameras of `placement` tell from their earlier pairs in `pairs`; printed. Returns
// false, after printing why, when the side is not typed and no camera can tell yet.
bool place_from_distances(const collect::PairsFile& pairs, const collect::Placement& placement, const collect::Entry& e,
                          const std::array<Eigen::Vector2d, 2>& candidates, Eigen::Vector3d& world);

}  // namespace cmd_collect
}  // namespace ips::cli
