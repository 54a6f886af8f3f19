// `ips collect`: calibration pairs from live cameras, the published procedure. For every
// placement the user puts the calibration marker down and types its measured world
// position (or two tape distances); every camera that sees the marker is read for --frames
// frames after the Enter key, through the daemon's own frame sources, detector, intrinsics
// and depth formula; a placement where the marker moved or was not seen steadily is refused.
// Each accepted placement appends one row per camera to the pairs CSV at once (undo and
// resume work on that file).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/aruco.hpp>

#include "collect_cameras.h"
#include "command.h"
#include "image_io.h"
#include "ips/core/clock.h"
#include "ips/collect/collect.h"
#include "ips/config/config.h"
#include "ips/detect/detector.h"
#include "ips/core/error.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/config/source_factory.h"

namespace fs = std::filesystem;

namespace ips::cli {
namespace cmd_collect {  // named, not anonymous: unique in a unity build

using collect::CameraVerdict;
using collect::Entry;

struct Args {
  std::string config, out, points;
  int marker = -1;
  int frames = 30;
  std::vector<std::string> cameras;
  std::vector<double> ref_a, ref_b;
  double max_spread = 0.01;
  double min_seen = 0.8;
};

std::string counts_text(const collect::PairsFile& pairs, const std::vector<CameraRun>& cams) {
  const auto n = pairs.counts();
  std::string s;
  for (const auto& c : cams) {
    const auto it = n.find(c.name);
    s += (s.empty() ? "" : ", ") + c.name + " " + std::to_string(it == n.end() ? 0 : it->second);
  }
  return s;
}

std::string xyz(const Eigen::Vector3d& p) {
  char buf[80];
  std::snprintf(buf, sizeof buf, "x %.3f  y %.3f  z %.3f m", p.x(), p.y(), p.z());
  return buf;
}

void say(const std::string& text) {
  std::fputs(text.c_str(), stdout);
  std::fflush(stdout);
}

void print_help(bool have_points, bool have_refs) {
  say("  Put the marker down, measure where its centre is, type it and press Enter:\n"
      "    x y z                world position in metres, e.g. 1.20 0.85 0.00 (z = height of the marker's face)\n");
  if (have_refs)
    say("    d DA DB Z [left|right]  floor distances from reference A and from B to the point under the\n"
        "                         marker's centre, and its height; the side of the line A->B is found by the\n"
        "                         cameras once they have 4 pairs, or give it (seen from A looking at B)\n");
  if (have_points)
    say("    (Enter)              the listed position as it is;  s  skip the listed position\n");
  say("    u                    undo the last placement;  q  quit (every placement is saved at once);  ?  help\n");
}

int run(const Args& a) {
  // ---- Check everything before opening a camera or writing anything.
  if (a.marker < 0) throw InputError("--marker: must be a marker id >= 0");
  if (a.frames < 1 || a.frames > 10000) throw InputError("--frames: must be 1..10000");
  if (!(a.max_spread > 0)) throw InputError("--max-spread: must be > 0 m");
  if (!(a.min_seen > 0 && a.min_seen <= 1)) throw InputError("--min-seen: must be in (0, 1]");
  const bool have_refs = !a.ref_a.empty() || !a.ref_b.empty();
  if (have_refs && (a.ref_a.size() != 2 || a.ref_b.size() != 2))
    throw InputError("--ref-a and --ref-b: give both, each as X Y in metres");
  const Eigen::Vector2d ref_a = have_refs ? Eigen::Vector2d(a.ref_a[0], a.ref_a[1]) : Eigen::Vector2d();
  const Eigen::Vector2d ref_b = have_refs ? Eigen::Vector2d(a.ref_b[0], a.ref_b[1]) : Eigen::Vector2d();
  if (have_refs && ((ref_a - ref_b).norm() < 0.1 || !ref_a.allFinite() || !ref_b.allFinite()))
    throw InputError("--ref-a, --ref-b: the reference points must be >= 0.1 m apart");
  const DaemonConfig config = load_config(a.config, ConfigChecks{.intrinsics_exist = true, .model_file_exists = false});
  const int dict_size =
      cv::aruco::getPredefinedDictionary(dictionary_id(config.detection.dictionary))->bytesList.rows;
  if (a.marker >= dict_size)
    throw InputError("--marker " + std::to_string(a.marker) + ": not in " +
                     config.detection.dictionary + " (0.." + std::to_string(dict_size - 1) + ")");
  std::vector<const CameraConfig*> selected;
  for (const auto& name : a.cameras) {
    const CameraConfig* found = nullptr;
    std::string names;
    for (const auto& c : config.cameras) {
      if (c.name == name) found = &c;
      names += (names.empty() ? "" : ", ") + c.name;
    }
    if (found == nullptr)
      throw InputError("--camera " + name + ": not in " + a.config + " (cameras: " + names + ")");
    selected.push_back(found);
  }
  if (a.cameras.empty())
    for (const auto& c : config.cameras) selected.push_back(&c);
  std::vector<Eigen::Vector3d> listed;
  if (!a.points.empty()) {
    std::ifstream in(a.points);
    if (!in) throw InputError(a.points + ": cannot open the list of positions");
    std::stringstream text;
    text << in.rdbuf();
    listed = collect::parse_points_csv(text.str(), a.points);
  }
  const fs::path out = a.out;
  if (!out.parent_path().empty() && !fs::is_directory(out.parent_path()))
    throw InputError("--out " + a.out + ": no such directory " + out.parent_path().string());
  collect::PairsFile pairs;
  bool resumed = false;
  if (fs::exists(out)) {
    std::ifstream in(out);
    std::stringstream text;
    text << in.rdbuf();
    pairs = collect::PairsFile::parse(text.str(), a.out);
    resumed = true;
  }

  // ---- The cameras, as the daemon runs them.
  SourceContext context;
  context.synthetic_epoch_mono_ns = monotonic_ns();
  std::vector<CameraRun> cams;
  for (const CameraConfig* c : selected) {
    cams.push_back(open_camera(*c, config, context, config.markers.sizes().length_of(a.marker)));
  }

  std::string cam_names;
  for (const auto& c : cams) cam_names += (cam_names.empty() ? "" : ", ") + c.name;
  char head[300];
  std::snprintf(head, sizeof head,
                "ips collect: marker %d (%s, %.3f m), %d frames per placement, cameras: %s\n",
                a.marker, config.detection.dictionary.c_str(),
                config.markers.sizes().length_of(a.marker), a.frames, cam_names.c_str());
  say(head);
  say("pairs file: " + a.out +
      (resumed ? " (resumed: " + std::to_string(pairs.placements().size()) +
                     " placement(s); pairs " + counts_text(pairs, cams) + ")\n"
               : " (new)\n"));
  if (have_refs)
    say("reference points: A " + xyz({ref_a.x(), ref_a.y(), 0}) + ", B " +
        xyz({ref_b.x(), ref_b.y(), 0}) + "\n");
  print_help(!listed.empty(), have_refs);

  collect::EntryLimits limits;
  collect::SteadyOptions steady;
  steady.max_spread = a.max_spread;
  steady.min_seen_fraction = a.min_seen;
  std::set<std::size_t> skipped;
  // A listed position counts as done when a placement in the file lies within 2 cm of it
  // (the typed, measured position may differ from the listed one by the tape's error).
  auto next_listed = [&]() -> long {
    for (std::size_t i = 0; i < listed.size(); ++i) {
      if (skipped.count(i)) continue;
      bool done = false;
      for (const auto& p : pairs.placements()) done = done || (p.world - listed[i]).norm() < 0.02;
      if (!done) return static_cast<long>(i);
    }
    return -1;
  };
  auto save = [&] { write_file_atomically(out, pairs.text()); };

  std::string line;
  while (true) {
    const long target = listed.empty() ? -1 : next_listed();
    if (!listed.empty() && target < 0) {
      say("every listed position is done or skipped\n");
      break;
    }
    const std::size_t number = pairs.placements().size() + 1;
    if (target >= 0) {
      say("placement " + std::to_string(number) + ": put the marker at " +
          xyz(listed[static_cast<std::size_t>(target)]) + " (listed " +
          std::to_string(target + 1) + "/" + std::to_string(listed.size()) +
          "), Enter when it lies still > ");
    } else {
      say("placement " + std::to_string(number) + ": position > ");
    }
    if (!std::getline(std::cin, line)) {
      say("\n(end of input)\n");
      break;
    }
    const std::int64_t entered_ns = monotonic_ns();
    Entry e;
    std::string error;
    if (!collect::parse_entry(line, limits, e, error)) {
      say("  not understood: " + error + "\n");
      continue;
    }
    Eigen::Vector3d world = Eigen::Vector3d::Zero();
    switch (e.kind) {
      case Entry::Kind::kHelp:
        print_help(!listed.empty(), have_refs);
        continue;
      case Entry::Kind::kQuit:
        break;
      case Entry::Kind::kUndo: {
        collect::Placement removed;
        if (!pairs.undo(removed)) {
          say("  nothing to undo\n");
          continue;
        }
        save();
        std::string which;
        for (const auto& c : removed.cameras) which += (which.empty() ? "" : ", ") + c.first;
        say("  undone: the placement at " + xyz(removed.world) + " (" + which + "); pairs " +
            counts_text(pairs, cams) + "\n");
        continue;
      }
      case Entry::Kind::kSkip:
        if (target < 0) {
          say("  nothing to skip (no --points list)\n");
        } else {
          skipped.insert(static_cast<std::size_t>(target));
          say("  skipped listed position " + std::to_string(target + 1) + "\n");
        }
        continue;
      case Entry::Kind::kAccept:
        if (target < 0) {
          say("  type the marker's position (x y z in metres), or ? for help\n");
          continue;
        }
        world = listed[static_cast<std::size_t>(target)];
        break;
      case Entry::Kind::kPosition:
        world = e.position;
        break;
      case Entry::Kind::kDistances:
        if (!have_refs) {
          say("  distances need the reference points: start with --ref-a X Y --ref-b X Y\n");
          continue;
        }
        break;
    }
    if (e.kind == Entry::Kind::kQuit) break;
    std::array<Eigen::Vector2d, 2> candidates;
    if (e.kind == Entry::Kind::kDistances) {
      try {
        candidates = collect::from_two_distances(ref_a, ref_b, e.d_a, e.d_b);
      } catch (const InputError& err) {
        say(std::string("  not understood: ") + err.what() + "\n");
        continue;
      }
    }

    // ---- Read every camera for --frames frames captured after the Enter key.
    say("  reading " + std::to_string(a.frames) + " frame(s) from " + std::to_string(cams.size()) +
        " camera(s)...\n");
    std::vector<Capture> captures(cams.size());
    {
      std::vector<std::thread> threads;
      for (std::size_t i = 0; i < cams.size(); ++i)
        threads.emplace_back([&, i] {
          try {
            captures[i] = capture(cams[i], a.marker, a.frames, entered_ns);
          } catch (const std::exception& err) {  // e.g. out of memory: report, do not terminate
            captures[i].problem = err.what();
          }
        });
      for (auto& t : threads) t.join();
    }
    collect::Placement placement;
    bool moved = false;
    for (std::size_t i = 0; i < cams.size(); ++i) {
      const CameraVerdict v = collect::judge(captures[i].samples, captures[i].frames, steady);
      char buf[300];
      std::snprintf(buf, sizeof buf, "  %-10s seen in %2d/%-2d frames", cams[i].name.c_str(),
                    v.seen, v.frames);
      std::string msg = buf;
      if (v.seen > 0) {
        std::snprintf(buf, sizeof buf, "  xc %+.4f yc %+.4f zc %.4f m  spread %.1f mm",
                      v.mean.x(), v.mean.y(), v.mean.z(), v.spread * 1000);
        msg += buf;
      }
      switch (v.kind) {
        case CameraVerdict::Kind::kNotSeen:
          msg += "  -> does not see it";
          break;
        case CameraVerdict::Kind::kIntermittent:
          msg += "  -> not steady (seen in fewer than " +
                 std::to_string(static_cast<int>(std::ceil(a.min_seen * a.frames - 1e-9))) +
                 "), not recorded";
          break;
        case CameraVerdict::Kind::kMoved:
          std::snprintf(buf, sizeof buf, "  -> MOVED (spread > %.1f mm)", a.max_spread * 1000);
          msg += buf;
          moved = true;
          break;
        case CameraVerdict::Kind::kSteady:
          msg += "  -> ok";
          placement.cameras.emplace_back(cams[i].name, v.mean);
          break;
      }
      if (!captures[i].problem.empty()) msg += "  [" + captures[i].problem + "]";
      say(msg + "\n");
    }
    if (moved) {
      say("  REFUSED: the marker moved while it was read; let it lie still and enter the "
          "position again\n");
      continue;
    }
    if (placement.cameras.empty()) {
      say("  REFUSED: no camera saw marker " + std::to_string(a.marker) +
          " steadily; nothing recorded\n");
      continue;
    }
    if (e.kind == Entry::Kind::kDistances) {
      int side = e.side == collect::Side::kLeft ? 0 : e.side == collect::Side::kRight ? 1 : -1;
      std::string how = side == 0 ? "left, as typed" : "right, as typed";
      if (side < 0) side = collect::side_from_cameras(pairs, placement.cameras, candidates, how);
      if (side < 0) {
        say("  REFUSED: the distances fit two places, " +
            xyz({candidates[0].x(), candidates[0].y(), e.z}) + " (left of A->B) and " +
            xyz({candidates[1].x(), candidates[1].y(), e.z}) +
            " (right); no camera has 4 pairs yet to tell which: add left or right\n");
        continue;
      }
      world = {candidates[static_cast<std::size_t>(side)].x(),
               candidates[static_cast<std::size_t>(side)].y(), e.z};
      say("  from the distances: " + xyz(world) + " (" + how + ")\n");
    }
    placement.world = world;
    pairs.add(placement);
    save();
    say("  recorded placement " + std::to_string(pairs.placements().size()) + " at " + xyz(world) +
        "; pairs " + counts_text(pairs, cams) + "\n");
  }
  for (auto& c : cams) c.source->close();
  say("done: " + std::to_string(pairs.placements().size()) + " placement(s) in " + a.out +
      "; pairs " + counts_text(pairs, cams) + "\n");
  return 0;
}

IPS_REGISTER_COMMAND(
    "collect",
    "Calibration pairs from live cameras: place the marker, type its world position, repeat",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      sub.add_option("--config", a->config,
                     "ipsd configuration: its cameras (any source), intrinsics, markers and detection")
          ->required();
      sub.add_option("--marker", a->marker, "Id of the calibration marker")->required();
      sub.add_option("--out", a->out,
                     "Pairs CSV (camera,xc,yc,zc,xw,yw,zw); an existing file is resumed")
          ->required();
      sub.add_option("--frames", a->frames, "Frames read per camera and placement")
          ->capture_default_str();
      sub.add_option("--camera", a->cameras, "Only these cameras (repeatable; default all)");
      sub.add_option("--points", a->points,
                     "CSV of world positions to place the marker at (columns xw,yw,zw)");
      sub.add_option("--ref-a", a->ref_a, "Reference point A on the floor, X Y metres (for d entries)")
          ->expected(2);
      sub.add_option("--ref-b", a->ref_b, "Reference point B on the floor, X Y metres")->expected(2);
      sub.add_option("--max-spread", a->max_spread,
                     "Refuse a placement where a frame's camera coordinates lie further than this "
                     "from their mean, metres (the marker moved)")
          ->capture_default_str();
      sub.add_option("--min-seen", a->min_seen,
                     "A camera must locate the marker in at least this fraction of the frames")
          ->capture_default_str();
      return [a] { return run(*a); };
    });

}  // namespace cmd_collect
}  // namespace ips::cli
