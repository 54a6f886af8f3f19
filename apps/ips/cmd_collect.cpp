// `ips collect`: calibration pairs from live cameras, the published procedure. For every
// placement the user puts the calibration marker down and types its measured world
// position (or two tape distances); every camera that sees the marker is read for --frames
// frames after the Enter key, through the daemon's own frame sources, detector, intrinsics
// and depth formula; a placement where the marker moved or was not seen steadily is refused.
// Each accepted placement appends one row per camera to the pairs CSV at once (undo and
// resume work on that file).
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/aruco.hpp>

#include "collect_cameras.h"
#include "collect_placement.h"
#include "command.h"
#include "image_io.h"
#include "ips/collect/collect.h"
#include "ips/config/config.h"
#include "ips/config/source_factory.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/geometry/marker_geometry.h"

namespace fs = std::filesystem;

namespace ips::cli {
namespace cmd_collect {  // named, not anonymous: unique in a unity build

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

// The floor reference points A and B of distances entries (--ref-a, --ref-b), if given.
struct References {
  bool given = false;
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();
};

// Everything a session works on, set up before the first placement.
struct Session {
  explicit Session(const Args& args) : a(args) {}

  const Args& a;
  References refs;
  std::vector<Eigen::Vector3d> listed;  // --points
  std::set<std::size_t> skipped;        // indices into `listed`
  collect::PairsFile pairs;
  std::vector<CameraRun> cams;
  ReadOptions reading;
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

void print_help(bool have_points, bool have_refs) {
  say("  Put the marker down, measure where its centre is, type it and press Enter:\n"
      "    x y z                world position in metres, e.g. 1.20 0.85 0.00 (z = height of the marker's face)\n");
  if (have_refs)
    say("    d DA DB Z [left|right]  floor distances from reference A and from B to the point under the\n"
        "                         marker's centre, and its height; the side of the line A->B is found by the\n"
        "                         cameras once they have 4 pairs, or give it (seen from A looking at B)\n");
  if (have_points) say("    (Enter)              the listed position as it is;  s  skip the listed position\n");
  say("    u                    undo the last placement;  q  quit (every placement is saved at once);  ?  help\n");
}

// ---- Checks before a camera is opened or anything written.

// The numeric options.
void check_options(const Args& a) {
  if (a.marker < 0) throw InputError("--marker: must be a marker id >= 0");
  if (a.frames < 1 || a.frames > 10000) throw InputError("--frames: must be 1..10000");
  if (!(a.max_spread > 0)) throw InputError("--max-spread: must be > 0 m");
  if (!(a.min_seen > 0 && a.min_seen <= 1)) throw InputError("--min-seen: must be in (0, 1]");
}

// --ref-a and --ref-b: both or neither, each X Y, at least 0.1 m apart.
References check_references(const Args& a) {
  References refs;
  refs.given = !a.ref_a.empty() || !a.ref_b.empty();
  if (!refs.given) return refs;
  if (a.ref_a.size() != 2 || a.ref_b.size() != 2)
    throw InputError("--ref-a and --ref-b: give both, each as X Y in metres");
  refs.a = Eigen::Vector2d(a.ref_a[0], a.ref_a[1]);
  refs.b = Eigen::Vector2d(a.ref_b[0], a.ref_b[1]);
  if ((refs.a - refs.b).norm() < 0.1 || !refs.a.allFinite() || !refs.b.allFinite())
    throw InputError("--ref-a, --ref-b: the reference points must be >= 0.1 m apart");
  return refs;
}

// --marker must be in the configured dictionary.
void check_marker(const Args& a, const DaemonConfig& config) {
  const int dict_size = cv::aruco::getPredefinedDictionary(dictionary_id(config.detection.dictionary))->bytesList.rows;
  if (a.marker >= dict_size)
    throw InputError("--marker " + std::to_string(a.marker) + ": not in " + config.detection.dictionary + " (0.." +
                     std::to_string(dict_size - 1) + ")");
}

// The cameras of `config` named by --camera, in that order; all of them without --camera.
std::vector<const CameraConfig*> select_cameras(const Args& a, const DaemonConfig& config) {
  std::vector<const CameraConfig*> selected;
  for (const auto& name : a.cameras) {
    const CameraConfig* found = nullptr;
    std::string names;
    for (const auto& c : config.cameras) {
      if (c.name == name) found = &c;
      names += (names.empty() ? "" : ", ") + c.name;
    }
    if (found == nullptr) throw InputError("--camera " + name + ": not in " + a.config + " (cameras: " + names + ")");
    selected.push_back(found);
  }
  if (a.cameras.empty())
    for (const auto& c : config.cameras) selected.push_back(&c);
  return selected;
}

// The positions listed in the --points file (none without --points).
std::vector<Eigen::Vector3d> read_listed(const std::string& points) {
  if (points.empty()) return {};
  std::ifstream in(points);
  if (!in) throw InputError(points + ": cannot open the list of positions");
  std::stringstream text;
  text << in.rdbuf();
  return collect::parse_points_csv(text.str(), points);
}

// The pairs file --out: its directory must exist; an existing file is read into `pairs` and
// resumed (returns true).
bool open_pairs(const std::string& out_name, collect::PairsFile& pairs) {
  const fs::path out = out_name;
  if (!out.parent_path().empty() && !fs::is_directory(out.parent_path()))
    throw InputError("--out " + out_name + ": no such directory " + out.parent_path().string());
  if (!fs::exists(out)) return false;
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  pairs = collect::PairsFile::parse(text.str(), out_name);
  return true;
}

// ---- The cameras, as the daemon runs them.
std::vector<CameraRun> open_cameras(const std::vector<const CameraConfig*>& selected, const DaemonConfig& config,
                                    int marker) {
  SourceContext context;
  context.synthetic_epoch_mono_ns = monotonic_ns();
  std::vector<CameraRun> cams;
  for (const CameraConfig* c : selected) {
    cams.push_back(open_camera(*c, config, context, config.markers.sizes().length_of(marker)));
  }
  return cams;
}

// What the session reads, into which file, and the help.
void print_start(const Session& s, const DaemonConfig& config, bool resumed) {
  std::string cam_names;
  for (const auto& c : s.cams) cam_names += (cam_names.empty() ? "" : ", ") + c.name;
  char head[300];
  std::snprintf(head, sizeof head, "ips collect: marker %d (%s, %.3f m), %d frames per placement, cameras: %s\n",
                s.a.marker, config.detection.dictionary.c_str(), config.markers.sizes().length_of(s.a.marker),
                s.a.frames, cam_names.c_str());
  say(head);
  say("pairs file: " + s.a.out +
      (resumed ? " (resumed: " + std::to_string(s.pairs.placements().size()) + " placement(s); pairs " +
                     counts_text(s.pairs, s.cams) + ")\n"
               : " (new)\n"));
  if (s.refs.given)
    say("reference points: A " + xyz({s.refs.a.x(), s.refs.a.y(), 0}) + ", B " + xyz({s.refs.b.x(), s.refs.b.y(), 0}) +
        "\n");
  print_help(!s.listed.empty(), s.refs.given);
}

// ---- The placements, one typed line at a time.

// The first listed position neither skipped nor done, or -1. A listed position counts as done
// when a placement in the file lies within 2 cm of it (the typed, measured position may differ
// from the listed one by the tape's error).
long next_listed(const Session& s) {
  for (std::size_t i = 0; i < s.listed.size(); ++i) {
    if (s.skipped.count(i)) continue;
    bool done = false;
    for (const auto& p : s.pairs.placements()) done = done || (p.world - s.listed[i]).norm() < 0.02;
    if (!done) return static_cast<long>(i);
  }
  return -1;
}

void save(const Session& s) { write_file_atomically(s.a.out, s.pairs.text()); }

// Asks for the next placement, at listed position `target` if >= 0.
void prompt(const Session& s, long target) {
  const std::size_t number = s.pairs.placements().size() + 1;
  if (target >= 0) {
    say("placement " + std::to_string(number) + ": put the marker at " +
        xyz(s.listed[static_cast<std::size_t>(target)]) + " (listed " + std::to_string(target + 1) + "/" +
        std::to_string(s.listed.size()) + "), Enter when it lies still > ");
  } else {
    say("placement " + std::to_string(number) + ": position > ");
  }
}

void undo(Session& s) {
  collect::Placement removed;
  if (!s.pairs.undo(removed)) {
    say("  nothing to undo\n");
    return;
  }
  save(s);
  std::string which;
  for (const auto& c : removed.cameras) which += (which.empty() ? "" : ", ") + c.first;
  say("  undone: the placement at " + xyz(removed.world) + " (" + which + "); pairs " + counts_text(s.pairs, s.cams) +
      "\n");
}

void skip(Session& s, long target) {
  if (target < 0) {
    say("  nothing to skip (no --points list)\n");
    return;
  }
  s.skipped.insert(static_cast<std::size_t>(target));
  say("  skipped listed position " + std::to_string(target + 1) + "\n");
}

// What to do after an entry: ask again, quit, or read the cameras for a placement.
enum class Next { kPrompt, kQuit, kRead };

// Carries out help, undo and skip; for a placement sets `world` (a distances entry's is
// found after the cameras are read).
Next handle_entry(Session& s, const Entry& e, long target, Eigen::Vector3d& world) {
  switch (e.kind) {
    case Entry::Kind::kHelp: print_help(!s.listed.empty(), s.refs.given); return Next::kPrompt;
    case Entry::Kind::kQuit: return Next::kQuit;
    case Entry::Kind::kUndo: undo(s); return Next::kPrompt;
    case Entry::Kind::kSkip: skip(s, target); return Next::kPrompt;
    case Entry::Kind::kAccept:
      if (target < 0) {
        say("  type the marker's position (x y z in metres), or ? for help\n");
        return Next::kPrompt;
      }
      world = s.listed[static_cast<std::size_t>(target)];
      return Next::kRead;
    case Entry::Kind::kPosition: world = e.position; return Next::kRead;
    case Entry::Kind::kDistances:
      if (!s.refs.given) {
        say("  distances need the reference points: start with --ref-a X Y --ref-b X Y\n");
        return Next::kPrompt;
      }
      return Next::kRead;
  }
  return Next::kPrompt;
}

// One entry typed at `entered_ns`: carried out, or the placement read, judged and recorded.
// Returns false to end the session.
bool do_entry(Session& s, const Entry& e, long target, std::int64_t entered_ns) {
  Eigen::Vector3d world = Eigen::Vector3d::Zero();
  const Next next = handle_entry(s, e, target, world);
  if (next != Next::kRead) return next != Next::kQuit;
  const bool distances = e.kind == Entry::Kind::kDistances;
  std::array<Eigen::Vector2d, 2> candidates;
  if (distances && !distance_candidates(s.refs.a, s.refs.b, e, candidates)) return true;
  collect::Placement placement;
  if (!read_placement(s.cams, s.reading, entered_ns, placement)) return true;
  if (distances && !place_from_distances(s.pairs, placement, e, candidates, world)) return true;
  placement.world = world;
  s.pairs.add(placement);
  save(s);
  say("  recorded placement " + std::to_string(s.pairs.placements().size()) + " at " + xyz(world) + "; pairs " +
      counts_text(s.pairs, s.cams) + "\n");
  return true;
}

// Prompts for and reads one line. Returns false to end the session: every listed position
// done or skipped, the end of the input, or q.
bool placement_step(Session& s) {
  const long target = s.listed.empty() ? -1 : next_listed(s);
  if (!s.listed.empty() && target < 0) {
    say("every listed position is done or skipped\n");
    return false;
  }
  prompt(s, target);
  std::string line;
  if (!std::getline(std::cin, line)) {
    say("\n(end of input)\n");
    return false;
  }
  const std::int64_t entered_ns = monotonic_ns();
  Entry e;
  std::string error;
  if (!collect::parse_entry(line, collect::EntryLimits{}, e, error)) {
    say("  not understood: " + error + "\n");
    return true;
  }
  return do_entry(s, e, target, entered_ns);
}

int run(const Args& a) {
  // Check everything before opening a camera or writing anything.
  check_options(a);
  const References refs = check_references(a);
  const DaemonConfig config = load_config(a.config, ConfigChecks{.intrinsics_exist = true, .model_file_exists = false});
  check_marker(a, config);
  const std::vector<const CameraConfig*> selected = select_cameras(a, config);
  Session s(a);
  s.refs = refs;
  s.listed = read_listed(a.points);
  const bool resumed = open_pairs(a.out, s.pairs);
  s.reading.marker = a.marker;
  s.reading.frames = a.frames;
  s.reading.steady.max_spread = a.max_spread;
  s.reading.steady.min_seen_fraction = a.min_seen;

  s.cams = open_cameras(selected, config, a.marker);
  print_start(s, config, resumed);
  while (placement_step(s)) {
  }
  for (auto& c : s.cams) c.source->close();
  say("done: " + std::to_string(s.pairs.placements().size()) + " placement(s) in " + a.out + "; pairs " +
      counts_text(s.pairs, s.cams) + "\n");
  return 0;
}

IPS_REGISTER_COMMAND(
    "collect", "Calibration pairs from live cameras: place the marker, type its world position, repeat",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      sub.add_option("--config", a->config,
                     "ipsd configuration: its cameras (any source), intrinsics, markers and detection")
          ->required();
      sub.add_option("--marker", a->marker, "Id of the calibration marker")->required();
      sub.add_option("--out", a->out, "Pairs CSV (camera,xc,yc,zc,xw,yw,zw); an existing file is resumed")->required();
      sub.add_option("--frames", a->frames, "Frames read per camera and placement")->capture_default_str();
      sub.add_option("--camera", a->cameras, "Only these cameras (repeatable; default all)");
      sub.add_option("--points", a->points, "CSV of world positions to place the marker at (columns xw,yw,zw)");
      sub.add_option("--ref-a", a->ref_a, "Reference point A on the floor, X Y metres (for d entries)")->expected(2);
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
