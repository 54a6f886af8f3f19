#include "collect_placement.h"

#include <cmath>
#include <cstdio>
#include <exception>
#include <thread>

#include "ips/core/error.h"

namespace ips::cli {
namespace cmd_collect {  // named, not anonymous: unique in a unity build

using collect::CameraVerdict;
using collect::Entry;

void say(const std::string& text) {
  std::fputs(text.c_str(), stdout);
  std::fflush(stdout);
}

std::string xyz(const Eigen::Vector3d& p) {
  char buf[80];
  std::snprintf(buf, sizeof buf, "x %.3f  y %.3f  z %.3f m", p.x(), p.y(), p.z());
  return buf;
}

// Every camera read at once, one thread each; an exception is kept as the camera's problem.
std::vector<Capture> capture_all(std::vector<CameraRun>& cams, int marker, int frames, std::int64_t entered_ns) {
  std::vector<Capture> captures(cams.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < cams.size(); ++i)
    threads.emplace_back([&, i] {
      try {
        captures[i] = capture(cams[i], marker, frames, entered_ns);
      } catch (const std::exception& err) {  // e.g. out of memory: report, do not terminate
        captures[i].problem = err.what();
      }
    });
  for (auto& t : threads) t.join();
  return captures;
}

// One camera's line, without the newline: how often it saw the marker, where and how steadily,
// its verdict and what cut its reading short.
std::string verdict_line(const std::string& name, const CameraVerdict& v, const Capture& c,
                         const ReadOptions& options) {
  char buf[300];
  std::snprintf(buf, sizeof buf, "  %-10s seen in %2d/%-2d frames", name.c_str(), v.seen, v.frames);
  std::string msg = buf;
  if (v.seen > 0) {
    std::snprintf(buf, sizeof buf, "  xc %+.4f yc %+.4f zc %.4f m  spread %.1f mm", v.mean.x(), v.mean.y(), v.mean.z(),
                  v.spread * 1000);
    msg += buf;
  }
  switch (v.kind) {
    case CameraVerdict::Kind::kNotSeen: msg += "  -> does not see it"; break;
    case CameraVerdict::Kind::kIntermittent:
      msg += "  -> not steady (seen in fewer than " +
             std::to_string(static_cast<int>(std::ceil(options.steady.min_seen_fraction * options.frames - 1e-9))) +
             "), not recorded";
      break;
    case CameraVerdict::Kind::kMoved:
      std::snprintf(buf, sizeof buf, "  -> MOVED (spread > %.1f mm)", options.steady.max_spread * 1000);
      msg += buf;
      break;
    case CameraVerdict::Kind::kSteady: msg += "  -> ok"; break;
  }
  if (!c.problem.empty()) msg += "  [" + c.problem + "]";
  return msg;
}

bool read_placement(std::vector<CameraRun>& cams, const ReadOptions& options, std::int64_t entered_ns,
                    collect::Placement& placement) {
  say("  reading " + std::to_string(options.frames) + " frame(s) from " + std::to_string(cams.size()) +
      " camera(s)...\n");
  const std::vector<Capture> captures = capture_all(cams, options.marker, options.frames, entered_ns);
  bool moved = false;
  for (std::size_t i = 0; i < cams.size(); ++i) {
    const CameraVerdict v = collect::judge(captures[i].samples, captures[i].frames, options.steady);
    if (v.kind == CameraVerdict::Kind::kMoved) moved = true;
    if (v.kind == CameraVerdict::Kind::kSteady) placement.cameras.emplace_back(cams[i].name, v.mean);
    say(verdict_line(cams[i].name, v, captures[i], options) + "\n");
  }
  if (moved) {
    say("  REFUSED: the marker moved while it was read; let it lie still and enter the "
        "position again\n");
    return false;
  }
  if (placement.cameras.empty()) {
    say("  REFUSED: no camera saw marker " + std::to_string(options.marker) + " steadily; nothing recorded\n");
    return false;
  }
  return true;
}

bool distance_candidates(const Eigen::Vector2d& ref_a, const Eigen::Vector2d& ref_b, const Entry& e,
                         std::array<Eigen::Vector2d, 2>& candidates) {
  try {
    candidates = collect::from_two_distances(ref_a, ref_b, e.d_a, e.d_b);
  } catch (const InputError& err) {
    say(std::string("  not understood: ") + err.what() + "\n");
    return false;
  }
  return true;
}

bool place_from_distances(const collect::PairsFile& pairs, const collect::Placement& placement, const Entry& e,
                          const std::array<Eigen::Vector2d, 2>& candidates, Eigen::Vector3d& world) {
  int side = e.side == collect::Side::kLeft ? 0 : e.side == collect::Side::kRight ? 1 : -1;
  std::string how = side == 0 ? "left, as typed" : "right, as typed";
  if (side < 0) side = collect::side_from_cameras(pairs, placement.cameras, candidates, how);
  if (side < 0) {
    say("  REFUSED: the distances fit two places, " + xyz({candidates[0].x(), candidates[0].y(), e.z}) +
        " (left of A->B) and " + xyz({candidates[1].x(), candidates[1].y(), e.z}) +
        " (right); no camera has 4 pairs yet to tell which: add left or right\n");
    return false;
  }
  world = {candidates[static_cast<std::size_t>(side)].x(), candidates[static_cast<std::size_t>(side)].y(), e.z};
  say("  from the distances: " + xyz(world) + " (" + how + ")\n");
  return true;
}

}  // namespace cmd_collect
}  // namespace ips::cli
