// bench_daemon: the real ipsd on 3 synthetic cameras (the published layout, four robots) at
// 30 fps with unsynchronised capture phases 0 / 11 / 23 ms, measured from outside:
//   - processing latency (frame delivered by its source -> sendto) and capture latency
//     (capture -> sendto) from the daemon's own status, sampled every 1 s status interval:
//     p50 = median of the intervals' p50, p99 = the largest interval p99 (an upper bound; the
//     median interval p99 beside it);
//     the synthetic cameras render ahead on their own niced threads ("sim:<name>") and deliver
//     each frame one frame period after its capture, so the renderer's cost is not measured;
//   - capture -> sendto from every datagram (publish time - header capture time, both
//     CLOCK_REALTIME; the publish time is stamped just before sendto), p50/p99/max;
//   - capture -> arrival at a local client, for reference;
//   - CPU per thread (capture threads "cam:<name>", workers "work:<k>" = JPEG decode + detect +
//     locate + map, "fusion", the simulator's "sim:<name>") from /proc/<pid>/task/*/stat, as a percentage of
//     one core; the daemon's total without the simulator; the machine's idle CPU (left over);
//   - per camera: frames per second, queue ms (delivery -> a worker starts it) and detect ms per
//     frame, markers per frame, drops and frames over budget.
// Usage: bench_daemon [--seconds S] [--fps F] [--tracking on|off] [--workers N] [--replay --cameras N
//        [--restart-rows R] [--aligned]] [--ipsd PATH] [--ips PATH]
//   --workers: processing.workers in the daemon's config (default: one per core).
//   --tracking: detection.tracking in the daemon's config (default: the daemon's default, on).
//   --replay --cameras N: instead of synthetic cameras, N file cameras replaying pre-rendered
//   1080p JPEG frames of the published lab (3 s rendered once by `ips sim render`, played
//   forwards and backwards in a loop, so that the markers never jump)
//   from memory (cameras[].preload): a real camera's cost to the daemon, without rendering.
//   Camera k replays the view of red/white/black (k mod 3) under its own name, with that
//   camera's model entry. A file source delivers a frame when it is read (no transport delay)
//   and never skips one: a daemon that cannot keep up shows as fps below the target (the
//   "shortfall"), not as drops.
//   Their phases are spread evenly over a frame period, as unsynchronised cameras' are likely
//   to be (--aligned: all deliver at the same instant, the worst case for the tail).
//   --restart-rows N: the replayed frames carry a restart marker every N MCU rows, as some
//   cameras' MJPEG does (region decodes then cut the rows they need out of the stream).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "child_process.h"
#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "loopback_udp.h"

namespace fs = std::filesystem;

namespace {

using ips::support::read_unix_socket;
using ips::support::run;
using ips::support::spawn;

// utime + stime (clock ticks) of every thread of `pid`, by thread name.
std::map<std::string, long> thread_cpu(pid_t pid) {
  std::map<std::string, long> out;
  const fs::path task = fs::path("/proc") / std::to_string(pid) / "task";
  std::error_code ec;
  for (const auto& t : fs::directory_iterator(task, ec)) {
    std::ifstream comm_file(t.path() / "comm");
    std::string comm;
    std::getline(comm_file, comm);
    std::ifstream stat_file(t.path() / "stat");
    std::string stat;
    std::getline(stat_file, stat);
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    std::string field;
    long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stol(field);
      if (i == 15) stime = std::stol(field);
    }
    out[comm] += utime + stime;
  }
  return out;
}

// A field of /proc/<pid>/status in MiB (VmRSS: resident now, VmHWM: peak resident).
double status_mib(pid_t pid, const std::string& field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(field + ":", 0) == 0) return std::stod(line.substr(field.size() + 1)) / 1024.0;  // kB
  }
  return NAN;
}

// Idle + iowait ticks of the whole machine (/proc/stat "cpu" line), all cores.
long machine_idle_ticks() {
  std::ifstream in("/proc/stat");
  std::string cpu;
  long user = 0, nice = 0, system = 0, idle = 0, iowait = 0;
  in >> cpu >> user >> nice >> system >> idle >> iowait;
  return idle + iowait;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t i =
      std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(p / 100.0 * static_cast<double>(v.size()))) - 1);
  return v[i];
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 20.0, fps = 30.0;
  std::string tracking;  // "" = the daemon's default
  int workers = 0;       // processing.workers; 0 = the daemon's default (one per core)
  bool replay = false;
  int n_cameras = 3;
  int restart_rows = 0;  // --restart-rows: restart markers in the replayed frames
  bool aligned = false;  // --aligned: every replayed camera delivers at the same instant
  const fs::path self = fs::read_symlink("/proc/self/exe");
  fs::path ipsd = self.parent_path().parent_path() / "ipsd";
  fs::path ips = self.parent_path().parent_path() / "ips";
  for (int i = 1; i < argc; i += 2) {
    std::string a = argv[i];
    if (a == "--replay" || a == "--aligned") {
      (a == "--replay" ? replay : aligned) = true;
      --i;
      continue;
    }
    if (i + 1 >= argc) a.clear();  // an option without its value: the usage below
    if (a == "--cameras")
      n_cameras = std::stoi(argv[i + 1]);
    else if (a == "--seconds")
      seconds = std::stod(argv[i + 1]);
    else if (a == "--fps")
      fps = std::stod(argv[i + 1]);
    else if (a == "--ipsd")
      ipsd = argv[i + 1];
    else if (a == "--ips")
      ips = argv[i + 1];
    else if (a == "--workers")
      workers = std::stoi(argv[i + 1]);
    else if (a == "--restart-rows")
      restart_rows = std::stoi(argv[i + 1]);
    else if (a == "--tracking" && (std::string(argv[i + 1]) == "on" || std::string(argv[i + 1]) == "off"))
      tracking = argv[i + 1];
    else {
      std::fprintf(
          stderr,
          "usage: bench_daemon [--seconds S] [--fps F] [--tracking on|off] [--workers N] [--replay --cameras N "
          "[--restart-rows R] [--aligned]] "
          "[--ipsd PATH] [--ips PATH]\n");
      return 2;
    }
  }
  const fs::path dir = fs::temp_directory_path() / ("bench_daemon_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path scene = fs::path(IPS_SOURCE_DIR) / "config/scenes/ou2023.yaml";
  const fs::path log = dir / "setup.log";
  std::printf("bench_daemon: fitting a plane model on simulated pairs...\n");
  std::fflush(stdout);
  if (run({ips.string(), "sim", "collect", "--scene", scene.string(), "--points", "20", "--out",
           (dir / "pairs.csv").string()},
          log) != 0 ||
      run({ips.string(), "fit", "--data", (dir / "pairs.csv").string(), "--method", "plane", "--out",
           (dir / "model.json").string()},
          log) != 0) {
    std::fprintf(stderr, "bench_daemon: model setup failed, see %s\n", log.c_str());
    return 1;
  }
  if (n_cameras < 1 || n_cameras > 32 || (!replay && n_cameras != 3)) {
    std::fprintf(stderr, "bench_daemon: --cameras is 1..32 and needs --replay\n");
    return 2;
  }
  const char* bases[] = {"red", "white", "black"};
  auto camera_name = [&](int k) {
    return k < 3 ? std::string(bases[k]) : std::string(bases[k % 3]) + "_" + std::to_string(k / 3);
  };
  if (replay) {
    std::printf("bench_daemon: rendering 3 s of frames for the replay...\n");
    std::fflush(stdout);
    const fs::path frames = dir / "frames";
    if (run({ips.string(), "sim", "render", "--scene", scene.string(), "--out", frames.string(), "--frames",
             std::to_string(static_cast<int>(3 * fps)), "--fps", std::to_string(fps), "--jpeg-restart-rows",
             std::to_string(restart_rows)},
            log) != 0) {
      std::fprintf(stderr, "bench_daemon: rendering failed, see %s\n", log.c_str());
      return 1;
    }
    for (const char* b : bases) fs::create_directories(frames / b);
    for (const auto& e : fs::directory_iterator(frames)) {
      const std::string f = e.path().filename().string();
      for (const char* b : bases)
        if (f.rfind(std::string(b) + "_", 0) == 0 && e.path().extension() == ".jpg")
          fs::rename(e.path(), frames / b / f);
    }
    // Played forwards then backwards (links to the same files), so that the loop has no jump: a
    // jump would make every tracked marker leave its ROI once per loop and fall back to a full
    // search in the frame's latency (1 frame in 90, enough to set the p99).
    for (const char* b : bases) {
      std::vector<fs::path> files;
      for (const auto& e : fs::directory_iterator(frames / b)) files.push_back(e.path());
      std::sort(files.begin(), files.end());
      for (std::size_t i = files.size() - 1, k = 0; i-- > 1; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "zz_back_%04zu.jpg", k);
        fs::create_symlink(files[i], frames / b / name);
      }
    }
    // Every replayed camera maps with the model entry of the camera whose view it replays.
    nlohmann::json model;
    std::ifstream(dir / "model.json") >> model;
    for (int k = 3; k < n_cameras; ++k) model["cameras"][camera_name(k)] = model["cameras"][bases[k % 3]];
    std::ofstream(dir / "model.json") << model.dump(1);
  }

  // The receiver, on a free loopback port.
  ips::support::UdpReceiver receiver;
  const int rx = receiver.fd;

  const std::string socket_path = (dir / "status.sock").string();
  std::ostringstream cameras;
  if (replay) {
    for (int k = 0; k < n_cameras; ++k) {
      const std::string b = bases[k % 3];
      // Unsynchronised cameras: capture phases spread evenly over a frame period (--aligned: all
      // at once, the worst case for the tail).
      const double phase = aligned ? 0.0 : k / (n_cameras * fps);
      cameras << "  - {name: " << camera_name(k) << ", source: file, path: " << (dir / "frames" / b).string()
              << ", fps: " << fps << ", phase: " << phase << ", preload: true, intrinsics: " << IPS_SOURCE_DIR
              << "/calib_data/ou2023/intrinsics_" << b << ".yaml}\n";
    }
  } else {
    cameras << "  - {name: red, source: synthetic, scene: " << scene.string() << ", fps: " << fps << ", phase: 0.000}\n"
            << "  - {name: white, source: synthetic, scene: " << scene.string() << ", fps: " << fps
            << ", phase: 0.011}\n"
            << "  - {name: black, source: synthetic, scene: " << scene.string() << ", fps: " << fps
            << ", phase: 0.023}\n";
  }
  std::ofstream(dir / "ipsd.yaml")
      << "cameras:\n"
      << cameras.str()
      << "markers:\n  ids:\n    1: {height: 0.15}\n    2: {height: 0.10}\n    3: {height: 0.0, edge_length: 0.15}\n"
      << "    4: {height: 0.05}\n"
      << (tracking.empty() ? "" : "detection: {tracking: " + std::string(tracking == "on" ? "true" : "false") + "}\n")
      << (workers > 0 ? "processing: {workers: " + std::to_string(workers) + "}\n" : "") << "model_file: model.json\n"
      << "outputs:\n  - {type: unicast, address: 127.0.0.1, port: " << receiver.port << ", format: binary}\n"
      << "status: {interval: 1, socket: " << socket_path << "}\n";
  const fs::path daemon_log = dir / "ipsd.log";
  const pid_t pid = spawn({ipsd.string(), "--config", (dir / "ipsd.yaml").string()}, daemon_log);

  auto receive_for = [&](double s, std::vector<double>* to_send, std::vector<double>* to_arrive, std::size_t* markers) {
    const std::int64_t end = ips::monotonic_ns() + static_cast<std::int64_t>(s * 1e9);
    std::vector<std::uint8_t> buf(65536);
    std::size_t n_dgrams = 0;
    while (ips::monotonic_ns() < end) {
      pollfd p{rx, POLLIN, 0};
      if (::poll(&p, 1, 100) != 1) continue;
      const ssize_t n = ::recv(rx, buf.data(), buf.size(), 0);
      const std::int64_t arrival = ips::realtime_ns();
      if (n <= 0) continue;
      try {
        const ips::Datagram d =
            ips::decode_datagram(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)));
        ++n_dgrams;
        if (to_send) to_send->push_back(1e-6 * static_cast<double>(d.publish_realtime_ns - d.capture_realtime_ns));
        if (to_arrive) to_arrive->push_back(1e-6 * static_cast<double>(arrival - d.capture_realtime_ns));
        if (markers) *markers += d.markers.size();
      } catch (const std::exception&) {
      }
    }
    return n_dgrams;
  };

  // Warm-up: the cameras open (renderer precomputation) and the first frames flow.
  std::printf("bench_daemon: ipsd pid %d, %d %s cameras at %.0f fps; warming up...\n", pid, n_cameras,
              replay ? "replayed" : "synthetic", fps);
  std::fflush(stdout);
  const std::int64_t warm_end = ips::monotonic_ns() + 30'000'000'000LL;
  while (ips::monotonic_ns() < warm_end && receive_for(0.5, nullptr, nullptr, nullptr) == 0) {
  }
  receive_for(2.0, nullptr, nullptr, nullptr);
  const auto status0 = nlohmann::json::parse(read_unix_socket(socket_path), nullptr, false);

  const long ticks = ::sysconf(_SC_CLK_TCK);
  const auto cpu0 = thread_cpu(pid);
  const double rss0 = status_mib(pid, "VmRSS");
  const std::int64_t t0 = ips::monotonic_ns();
  const auto idle0 = machine_idle_ticks();
  std::vector<double> to_send, to_arrive;
  std::vector<double> proc50, proc99, cap50, cap99;
  std::size_t markers = 0, datagrams = 0;
  for (double left = seconds; left > 0; left -= 1.0) {  // one daemon status interval per step
    datagrams += receive_for(std::min(1.0, left), &to_send, &to_arrive, &markers);
    const auto s = nlohmann::json::parse(read_unix_socket(socket_path), nullptr, false);
    if (!s.is_object() || !s.contains("processing_latency_ms") || s["processing_latency_ms"]["p50"].is_null()) continue;
    proc50.push_back(s["processing_latency_ms"]["p50"]);
    proc99.push_back(s["processing_latency_ms"]["p99"]);
    cap50.push_back(s["capture_latency_ms"]["p50"]);
    cap99.push_back(s["capture_latency_ms"]["p99"]);
  }
  const double wall = 1e-9 * static_cast<double>(ips::monotonic_ns() - t0);
  const auto idle1 = machine_idle_ticks();
  const auto cpu1 = thread_cpu(pid);
  const double rss1 = status_mib(pid, "VmRSS"), rss_peak = status_mib(pid, "VmHWM");
  const auto status = nlohmann::json::parse(read_unix_socket(socket_path), nullptr, false);
  ::kill(pid, SIGTERM);
  int ws = 0;
  ::waitpid(pid, &ws, 0);

  std::printf("\nbench_daemon: %.1f s measured, %zu datagrams (%.1f/s), %.2f markers per datagram\n", wall, datagrams,
              static_cast<double>(datagrams) / wall,
              datagrams ? static_cast<double>(markers) / static_cast<double>(datagrams) : 0.0);
  std::printf("daemon, %zu status intervals of 1 s:\n", proc50.size());
  std::printf(
      "processing latency (delivered -> sendto)  p50 %6.1f ms   p99 %6.1f ms (largest interval p99; median %.1f)\n",
      percentile(proc50, 50), percentile(proc99, 100), percentile(proc99, 50));
  std::printf(
      "capture latency    (capture -> sendto)    p50 %6.1f ms   p99 %6.1f ms (largest interval p99; median %.1f)\n",
      percentile(cap50, 50), percentile(cap99, 100), percentile(cap99, 50));
  std::printf("from the datagrams:\n");
  std::printf("latency capture -> sendto   p50 %7.1f ms   p99 %7.1f ms   max %7.1f ms\n", percentile(to_send, 50),
              percentile(to_send, 99), percentile(to_send, 100));
  std::printf("latency capture -> client   p50 %7.1f ms   p99 %7.1f ms   max %7.1f ms\n", percentile(to_arrive, 50),
              percentile(to_arrive, 99), percentile(to_arrive, 100));
  // Every update comes from one camera frame, and a synthetic frame is handed over no earlier
  // than its capture + the transport delay (one frame period here). So over ALL datagrams
  // processing (delivered -> sendto) <= (capture -> sendto) - delay, quantile by quantile: the
  // pooled p99 the per-interval status figures cannot give.
  const double delay_ms = replay ? 0.0 : 1000.0 / fps;  // a file source hands a frame over when read
  std::printf(
      "processing, all datagrams  p50 <= %5.1f ms   p99 <= %5.1f ms   max <= %5.1f ms  (capture -> sendto - %.1f ms "
      "transport)\n",
      percentile(to_send, 50) - delay_ms, percentile(to_send, 99) - delay_ms, percentile(to_send, 100) - delay_ms,
      delay_ms);
  // Threads: the capture threads "cam:<name>" only dequeue; the workers "work:<k>" decode, detect,
  // locate and map; "fusion" fuses and sends; the simulator's "sim:<name>" render.
  std::printf("%-12s %8s\n", "thread", "CPU %");
  long total = 0, simulator = 0, pipeline_ticks = 0;
  for (const auto& [name, t1] : cpu1) {
    const long used = t1 - (cpu0.count(name) ? cpu0.at(name) : 0);
    total += used;
    if (name.rfind("sim:", 0) == 0) simulator += used;
    if (name.rfind("cam:", 0) == 0 || name.rfind("work:", 0) == 0) pipeline_ticks += used;
    std::printf("%-12s %8.1f\n", name.c_str(), 100.0 * static_cast<double>(used) / static_cast<double>(ticks) / wall);
  }
  // Cameras, over the measured window (differences of the daemon's cumulative counters): queue =
  // mean wait from delivery until a worker started the frame, detect = the work on it.
  double fps_sum = 0, camera_frames = 0;
  int fps_n = 0;
  if (status.is_object()) {
    std::printf("%-12s %8s %9s %10s %8s %8s %11s\n", "camera", "fps", "queue ms", "detect ms", "markers", "drops",
                "over budget");
    for (std::size_t i = 0; i < status["cameras"].size(); ++i) {
      const auto& c = status["cameras"][i];
      const auto& c0 = status0.is_object() ? status0["cameras"][i] : c;
      const auto delta = [&](const char* key) { return c.value(key, 0ULL) - c0.value(key, 0ULL); };
      const auto frames = delta("frames");
      const double detect_s = c.value("detect_s_total", 0.0) - c0.value("detect_s_total", 0.0);
      const double queue_s = c.value("queue_s_total", 0.0) - c0.value("queue_s_total", 0.0);
      const double per_frame = frames ? 1.0 / static_cast<double>(frames) : 0.0;
      fps_sum += static_cast<double>(frames) / wall;
      ++fps_n;
      camera_frames += static_cast<double>(frames);
      std::printf("%-12s %8.1f %9.1f %10.1f %8.2f %8llu %11llu\n", c.value("name", "").c_str(),
                  static_cast<double>(frames) / wall, 1e3 * queue_s * per_frame, 1e3 * detect_s * per_frame,
                  static_cast<double>(delta("markers_total")) * per_frame,
                  static_cast<unsigned long long>(delta("drops")),
                  static_cast<unsigned long long>(delta("over_budget")));
    }
  }
  // A daemon left running for months must not grow: run with a long --seconds to soak.
  std::printf(
      "memory: resident %.1f MiB at the start of the measurement, %.1f MiB at its end (%+.2f MiB), peak %.1f MiB\n",
      rss0, rss1, rss1 - rss0, rss_peak);
  const double to_pct = 100.0 / static_cast<double>(ticks) / wall;
  std::printf("%-12s %8.1f   (%u hardware threads)\n", "ipsd total", static_cast<double>(total) * to_pct,
              std::thread::hardware_concurrency());
  std::printf("%-12s %8.1f   (the daemon without its simulated cameras' renderers)\n", "daemon",
              static_cast<double>(total - simulator) * to_pct);
  std::printf("%-12s %8.1f   (machine idle over the measurement: CPU left over, all processes)\n", "idle",
              static_cast<double>(idle1 - idle0) * to_pct);
  if (fps_n > 0)
    std::printf("%-12s %8.1f   (mean camera fps vs %.0f: frames short %.2f %%)\n", "fps", fps_sum / fps_n, fps,
                100.0 * std::max(0.0, 1.0 - fps_sum / fps_n / fps));
  // CPU per processed frame of the capture threads and the workers: what a camera costs, much less
  // sensitive to other processes' load than the totals above (which drop when the daemon gets less CPU).
  if (camera_frames > 0) {
    const double ms_per_frame = 1e3 * static_cast<double>(pipeline_ticks) / static_cast<double>(ticks) / camera_frames;
    std::printf(
        "%-12s %8.2f   (capture + worker threads' CPU ms per frame; x %d cameras x %.0f fps = %.1f %% of one core)\n",
        "per frame", ms_per_frame, n_cameras, fps, ms_per_frame * n_cameras * fps / 10.0);
  }
  fs::remove_all(dir);
  return 0;
}
