// `ips localise`: a robot's poses from its own up-facing camera and a map of the ceiling's
// markers (inside-out, docs/inside-out.md), offline: from a folder of frames with their
// capture times, or from an `ips record` session of that camera. One row per frame in which a
// marker of the map placed the robot, its t_ns echoed exactly.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "command.h"
#include "drive_input.h"
#include "image_io.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/insideout/ceiling_map.h"
#include "ips/insideout/localise.h"
#include "ips/insideout/robot_config.h"

namespace fs = std::filesystem;

namespace cmd_localise {  // named, not anonymous: unique in a unity build

struct Args {
  std::string map, config, images, session, camera, out;
};

int run(const Args& a) {
  const ips::CeilingMap map = ips::CeilingMap::load(a.map);
  ips::RobotCameraConfig config = ips::load_robot_config(a.config);
  config.detection.dictionary = map.dictionary;
  const ips::CameraModel camera = ips::CameraModel::load(config.intrinsics);
  const bool from_images = !a.images.empty();
  const std::vector<ips::cli::FrameInput> frames =
      from_images ? ips::cli::read_times_csv(a.images) : ips::cli::read_session_frames(a.session, a.camera, camera);
  ips::Detector detector(config.detection);

  std::string csv = "t_ns,x,y,z,yaw,sx,sy,syaw,markers\n";
  long placed = 0, markers_used = 0;
  std::set<int> unknown, rejected;
  std::map<std::string, long> why;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const ips::cli::FrameInput& f = frames[k];
    const auto found = ips::cli::detections_of(f, detector, camera, config.intrinsics.string());
    const ips::Localisation l = ips::localise(found, camera, map, config.mount, config.localise);
    unknown.insert(l.unknown.begin(), l.unknown.end());
    rejected.insert(l.rejected.begin(), l.rejected.end());
    if (!l.ok) {
      ++why[l.why];
    } else {
      ++placed;
      markers_used += static_cast<long>(l.used.size());
      const auto& p = l.pose;
      char row[256];
      std::snprintf(row, sizeof row, "%lld,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%zu\n", static_cast<long long>(f.t_ns),
                    p.position.x(), p.position.y(), p.position.z(), p.yaw, std::sqrt(p.covariance(0, 0)),
                    std::sqrt(p.covariance(1, 1)), std::sqrt(p.covariance(3, 3)), l.used.size());
      csv += row;
    }
    if (from_images && ((k + 1) % 25 == 0 || k + 1 == frames.size())) {
      std::fprintf(stderr, "\rframe %zu/%zu, %ld placed", k + 1, frames.size(), placed);
    }
  }
  if (from_images) std::fprintf(stderr, "\n");
  ips::cli::write_file_atomically(a.out, csv);
  std::printf("%ld of %zu frames placed the robot (%.1f markers each on average); wrote %s\n", placed, frames.size(),
              placed > 0 ? static_cast<double>(markers_used) / static_cast<double>(placed) : 0.0, a.out.c_str());
  for (const auto& [reason, n] : why) std::printf("  %ld frame(s): %s\n", n, reason.c_str());
  auto list = [](const std::set<int>& ids) {
    std::string s;
    for (int id : ids) s += (s.empty() ? "" : " ") + std::to_string(id);
    return s;
  };
  if (!unknown.empty()) std::printf("  ids seen that the map does not have: %s\n", list(unknown).c_str());
  if (!rejected.empty()) {
    std::printf("  ids left out where they disagreed with the others (moved since mapping?): %s\n",
                list(rejected).c_str());
  }
  return placed > 0 ? 0 : 1;
}

IPS_REGISTER_COMMAND(
    "localise", "A robot's poses from its up-facing camera and a map of the ceiling's markers (inside-out)",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      sub.add_option("--map", a->map, "The ceiling's marker map (map.json)")->required()->check(CLI::ExistingFile);
      sub.add_option("--config", a->config, "The robot's camera: robot.yaml (intrinsics, mount)")
          ->required()
          ->check(CLI::ExistingFile);
      auto* images = sub.add_option("--images", a->images, "A folder of frames with times.csv (file,t_ns)");
      auto* session = sub.add_option("--session", a->session, "An ips record session of the robot's camera");
      images->excludes(session);
      sub.add_option("--camera", a->camera, "The session's camera (when it has several)")->needs(session);
      sub.add_option("--out", a->out, "poses.csv: t_ns,x,y,z,yaw,sx,sy,syaw,markers (m, rad, world frame)")->required();
      return [a] {
        if (a->images.empty() && a->session.empty()) throw ips::InputError("give --images DIR or --session DIR");
        return run(*a);
      };
    });

}  // namespace cmd_localise
