// `ips record`: every camera's marker detections for `ips survey`, written as they happen.
// The cameras are opened exactly as `ips collect` and the daemon open them (collect_cameras);
// each camera runs on a thread of its own and appends one line per detected marker to its
// own file (format: include/ips/survey/survey.h, docs/survey.md), flushed every frame, so
// a session cut short still holds everything up to the cut.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "collect_cameras.h"
#include "command.h"
#include "image_io.h"
#include "ips/config/config.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/survey/survey.h"

namespace fs = std::filesystem;

namespace ips::cli {
namespace cmd_record {  // named, not anonymous: unique in a unity build

struct Args {
  std::string config, out;
  double seconds = 0.0;
  bool virtual_time = false;
};

struct Counters {
  std::atomic<long> frames{0}, detections{0};
  std::atomic<std::int64_t> last_t_ns{0};  // the newest frame's capture time
  std::atomic<bool> done{false};
  std::mutex mutex;
  std::set<int> ids;
  std::string problem;
};

// Until the clock passes `end_ns`, or on virtual time until a frame is stamped past it.
void record_camera(CameraRun& cam, const fs::path& file, std::int64_t start_ns, std::int64_t end_ns, bool virtual_time,
                   Counters& count) {
  std::ofstream out(file, std::ios::app);
  out << "# camera " << cam.name << ": t_ns id x0 y0 x1 y1 x2 y2 x3 y3 (t_ns since the session start)\n";
  Frame f;
  while (virtual_time || monotonic_ns() < end_ns) {
    FrameSource::ReadStatus status;
    try {
      status = cam.source->read(f, std::chrono::milliseconds(100));
    } catch (const SourceError& e) {
      {
        const std::lock_guard<std::mutex> lock(count.mutex);
        count.problem = e.what();
      }
      cam.source->close();
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      try {
        cam.source->open();
      } catch (const std::exception&) {
      }
      continue;
    }
    if (status == FrameSource::ReadStatus::kEnd) {
      const std::lock_guard<std::mutex> lock(count.mutex);
      count.problem = "the source ended";
      break;
    }
    if (status != FrameSource::ReadStatus::kFrame || f.t_mono_ns < start_ns) continue;
    if (f.t_mono_ns > end_ns) break;
    count.last_t_ns = f.t_mono_ns;
    if (f.gray.size() != cam.model.size()) {
      const std::lock_guard<std::mutex> lock(count.mutex);
      count.problem = "frames are " + std::to_string(f.gray.cols) + "x" + std::to_string(f.gray.rows) +
                      " but the intrinsics are for " + std::to_string(cam.model.size().width) + "x" +
                      std::to_string(cam.model.size().height);
      continue;
    }
    ++count.frames;
    for (const auto& d : cam.detector->detect(f.gray, &cam.model)) {
      survey::Detection det;
      det.t_ns = f.t_mono_ns - start_ns;
      det.id = d.id;
      det.corners = d.corners_px;
      out << survey::detection_line(det) << '\n';
      ++count.detections;
      const std::lock_guard<std::mutex> lock(count.mutex);
      count.ids.insert(d.id);
    }
    out.flush();
  }
  count.done = true;
}

int run(const Args& a) {
  if (!(a.seconds > 0 && a.seconds <= 3600)) throw InputError("--seconds: must be in (0, 3600]");
  const DaemonConfig config = load_config(a.config, ConfigChecks{.intrinsics_exist = true, .model_file_exists = false});
  const fs::path dir = a.out;
  if (fs::exists(dir / "session.txt"))
    throw InputError("--out " + a.out + ": already holds a session (session.txt); choose another directory");
  if (fs::exists(dir) && !fs::is_directory(dir)) throw InputError("--out " + a.out + ": not a directory");
  const fs::path parent = fs::absolute(dir).parent_path();
  if (!fs::is_directory(parent)) throw InputError("--out " + a.out + ": no such directory " + parent.string());

  SourceContext context;
  context.synthetic_epoch_mono_ns = monotonic_ns();
  context.virtual_time = a.virtual_time;
  std::vector<CameraRun> cams;
  std::vector<std::pair<std::string, CameraModel>> models;
  for (const auto& c : config.cameras) {
    cams.push_back(open_camera(c, config, context, config.markers.edge_length));
    models.emplace_back(c.name, cams.back().model);
  }
  fs::create_directories(dir);
  survey::Session session;
  session.config = fs::absolute(a.config).lexically_normal().string();
  session.fingerprint = survey::camera_fingerprint(models);
  session.dictionary = config.detection.dictionary;
  session.seconds = a.seconds;
  for (const auto& c : cams) session.cameras.push_back({c.name, c.name + ".det", {}});
  write_file_atomically(dir / "session.txt", survey::session_header(session));

  std::printf(
      "ips record: %zu camera(s) for %.0f s into %s; walk the wand through every view, pausing "
      "~1 s now and then where two cameras see it\n",
      cams.size(), a.seconds, a.out.c_str());
  std::fflush(stdout);
  // Virtual time: the session is scene time 0 to `seconds`, however long it takes to render.
  const std::int64_t start = a.virtual_time ? context.synthetic_epoch_mono_ns : monotonic_ns();
  const std::int64_t end = start + static_cast<std::int64_t>(a.seconds * 1e9);
  std::vector<std::unique_ptr<Counters>> counts;
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < cams.size(); ++i) {
    counts.push_back(std::make_unique<Counters>());
    threads.emplace_back(record_camera, std::ref(cams[i]), dir / session.cameras[i].file, start, end, a.virtual_time,
                         std::ref(*counts[i]));
  }
  const bool tty = ::isatty(STDOUT_FILENO) != 0;
  std::vector<long> last(cams.size(), 0);
  int tick = 0;
  const auto all_done = [&] {
    return std::all_of(counts.begin(), counts.end(), [](const auto& c) { return c->done.load(); });
  };
  while (a.virtual_time ? !all_done() : monotonic_ns() < end) {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    ++tick;
    // Virtual time: how far the slowest camera got in scene time (and frames per wall second).
    std::int64_t reached = end;
    for (const auto& c : counts)
      if (!c->done) reached = std::min(reached, c->last_t_ns.load());
    std::string line = a.virtual_time
                           ? "scene time " + std::to_string(std::max<std::int64_t>(0, reached - start) / 1000000000) +
                                 "/" + std::to_string(static_cast<int>(a.seconds)) + " s (virtual time)"
                           : std::to_string(tick) + "/" + std::to_string(static_cast<int>(a.seconds)) + " s";
    for (std::size_t i = 0; i < cams.size(); ++i) {
      const long f = counts[i]->frames.load();
      std::string ids;
      {
        const std::lock_guard<std::mutex> lock(counts[i]->mutex);
        for (int id : counts[i]->ids) ids += (ids.empty() ? "" : ",") + std::to_string(id);
        if (!counts[i]->problem.empty()) ids += " PROBLEM: " + counts[i]->problem;
      }
      line += "  " + cams[i].name + ": " + std::to_string(f - last[i]) + " fps, markers [" + ids + "]";
      last[i] = f;
    }
    if (tty)
      std::printf("\r%s\033[K", line.c_str());
    else if (tick % 5 == 0)
      std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  }
  for (auto& t : threads) t.join();
  for (auto& c : cams) c.source->close();
  session.seconds = a.virtual_time ? a.seconds : static_cast<double>(monotonic_ns() - start) * 1e-9;
  write_file_atomically(dir / "session.txt", survey::session_header(session));
  if (tty) std::printf("\n");
  for (std::size_t i = 0; i < cams.size(); ++i)
    std::printf("%s: %ld frames, %ld detections -> %s\n", cams[i].name.c_str(), counts[i]->frames.load(),
                counts[i]->detections.load(), (dir / session.cameras[i].file).c_str());
  return 0;
}

IPS_REGISTER_COMMAND(
    "record", "Record every camera's marker detections for `ips survey` (wand session)",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      sub.add_option("--config", a->config, "ipsd configuration: its cameras (any source), intrinsics, detection")
          ->required();
      sub.add_option("--seconds", a->seconds, "How long to record, seconds")->required();
      sub.add_option("--out", a->out, "Session directory (created; must not hold a session already)")->required();
      sub.add_flag("--virtual-time", a->virtual_time,
                   "Synthetic and file cameras only: record --seconds of scene time, every frame, as fast as they "
                   "render (stamped with their exact capture times; a busy machine drops nothing)");
      return [a] { return run(*a); };
    });

}  // namespace cmd_record
}  // namespace ips::cli
