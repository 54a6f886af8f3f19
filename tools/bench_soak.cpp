// bench_soak: the real ipsd for a long time on 3 emulated V4L2 cameras (the LD_PRELOAD
// emulator of tests/capture, serving pre-rendered 1080p MJPEG frames of the published lab)
// with faults injected on a schedule, watched from outside. docs/reliability.md.
//
// Every --period seconds one fault, in this rotation (one cycle = 8 periods):
//   unplug     a camera disappears (open/ioctl fail, ENODEV) for 10 s, then comes back
//   corrupt    a camera delivers every 3rd frame truncated, for 15 s
//   hup-good   SIGHUP with a changed fusion window (applied without restarting cameras)
//   garbage    random datagrams at the subscriptions port, junk and stalled connections at
//              the web port and the status socket, then the web and status answers checked
//   unplug     (the next camera)
//   hup-bad    SIGHUP with a broken file (YAML syntax, unknown key, missing model, bad value,
//              in turn): must be refused, the old configuration kept
//   listener   a subscribed `ips listen` is killed (SIGKILL, no unsubscribe) and the listener
//              of the second unicast output closes its socket for 15 s, then reopens
//   hup-cams   SIGHUP with one camera's exposure changed (the camera threads restart)
// Measured: crashes, threads/fds/resident memory every 10 s, the 1-minute load average beside
// them, per-camera silences in the stream longer than --gap (excused only for an unplugged
// camera until it is back, and for every camera across a camera restart), datagrams lost,
// WATCHDOG=1 pings on a fake NOTIFY_SOCKET (WATCHDOG_USEC as the packaged unit's
// WatchdogSec=10), recovery = fault end -> every camera's first record captured after it.
// Writes OUT/summary.json (machine-readable), OUT/summary.txt (tables), OUT/samples.csv,
// OUT/ipsd.log; progress on stdout.
// Usage: bench_soak --out DIR [--seconds S=300] [--fps F=10] [--period P=30] [--gap G=1.0]
//                   [--watchdog-sec W=10] [--nice N=-5] [--ipsd PATH] [--ips PATH] [--emu LIB]
// --nice: ipsd runs under `nice -n N`, as the packaged unit's Nice=-5 (packaging/ipsd.service.in)
// protects it from batch load on the lab PC; 0 = normal priority. The niceness ipsd actually had
// (raising priority needs root or CAP_SYS_NICE) is read from /proc and reported.
#include <signal.h>
#include <sys/wait.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <tuple>

#include <nlohmann/json.hpp>

#include "child_process.h"
#include "soak_faults.h"
#include "soak_monitor.h"
#include "soak_report.h"

namespace fs = std::filesystem;
using namespace ips::soak;

namespace {

const char* const kCams[] = {"red", "white", "black"};
constexpr int kNCams = 3;

std::int64_t now_ns() { return ips::monotonic_ns(); }
void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

// The niceness a process runs at (/proc/PID/stat field 19); nullopt if it cannot be read.
std::optional<int> process_nice(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  std::getline(in, stat);  // one line
  const auto paren = stat.rfind(')');
  if (paren == std::string::npos) return std::nullopt;
  std::istringstream fields(stat.substr(paren + 2));  // field 3 (state) onwards
  std::string f;
  for (int i = 3; i < 19 && fields >> f; ++i) {
  }
  int nice = 0;
  if (!(fields >> nice)) return std::nullopt;
  return nice;
}

int count_lines(const fs::path& log, const std::string& what) {
  std::ifstream in(log);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += line.find(what) != std::string::npos;
  return n;
}

// Waits up to `s` seconds for `log` to hold more than `before` lines containing `what`.
bool wait_log(const fs::path& log, const std::string& what, int before, double s) {
  const std::int64_t end = now_ns() + static_cast<std::int64_t>(s * 1e9);
  while (now_ns() < end) {
    if (count_lines(log, what) > before) return true;
    sleep_s(0.1);
  }
  return false;
}

void write_control(const fs::path& path, const std::map<std::string, std::string>& kv) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    for (const auto& [k, v] : kv) out << k << '=' << v << '\n';
  }
  fs::rename(tmp, path);  // atomically: the emulator re-reads a changed inode
}

int udp_socket_on(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Datagrams waiting on `fd`, read and discarded; true if any arrives within `s` seconds.
bool received_within(int fd, double s) {
  char buf[65536];
  const std::int64_t end = now_ns() + static_cast<std::int64_t>(s * 1e9);
  bool any = false;
  while (now_ns() < end && !any) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) == 1 && ::recv(fd, buf, sizeof buf, 0) > 0) any = true;
  }
  while (::recv(fd, buf, sizeof buf, MSG_DONTWAIT) > 0) {
  }
  return any;
}

struct Options {
  double seconds = 300, fps = 10, period = 30, gap = 1.0, watchdog_s = 10;
  int nice = -5;  // the packaged unit's Nice=
  fs::path out, ipsd, ips, emu;
};

struct ConfigVariant {
  double window = 0.02;
  double black_exposure = 0.004;
  std::string bad;  // "" = a good file
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const fs::path build = self.parent_path().parent_path();
  o.ipsd = build / "ipsd";
  o.ips = build / "ips";
  o.emu = build / "tests/libips_v4l2_emu.so";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--seconds")
      o.seconds = std::stod(v);
    else if (a == "--fps")
      o.fps = std::stod(v);
    else if (a == "--period")
      o.period = std::stod(v);
    else if (a == "--gap")
      o.gap = std::stod(v);
    else if (a == "--watchdog-sec")
      o.watchdog_s = std::stod(v);
    else if (a == "--out")
      o.out = v;
    else if (a == "--ipsd")
      o.ipsd = v;
    else if (a == "--ips")
      o.ips = v;
    else if (a == "--emu")
      o.emu = v;
    else if (a == "--nice")
      o.nice = std::stoi(v);
    else
      o.out.clear(), i = argc;
  }
  if (o.out.empty() || argc % 2 == 0 || o.period < 25 || o.fps <= 0 || o.seconds <= 0) {
    std::fprintf(stderr,
                 "usage: bench_soak --out DIR [--seconds S] [--fps F] [--period P>=25] [--gap G] [--watchdog-sec W]\n"
                 "                  [--nice N] [--ipsd PATH] [--ips PATH] [--emu LIB]\n");
    return 2;
  }
  for (const auto& f : {o.ipsd, o.ips, o.emu})
    if (!fs::exists(f)) {
      std::fprintf(stderr, "bench_soak: %s not found (build ipsd, ips_tool and ips_v4l2_emu, or pass its path)\n",
                   f.c_str());
      return 2;
    }
  fs::create_directories(o.out);
  const fs::path dir = fs::absolute(o.out) / "work";
  fs::create_directories(dir);
  const fs::path setup_log = dir / "setup.log", log = fs::absolute(o.out) / "ipsd.log";
  fs::remove(log);
  const fs::path scene = fs::path(IPS_SOURCE_DIR) / "config/scenes/ou2023.yaml";
  const std::string ips = o.ips.string();

  std::printf("bench_soak: fitting a plane model and rendering %d frames per camera...\n", static_cast<int>(3 * o.fps));
  std::fflush(stdout);
  using ips::support::run;
  fs::remove_all(dir / "frames");
  if (run({ips, "sim", "collect", "--scene", scene.string(), "--points", "20", "--out", (dir / "pairs.csv").string()},
          setup_log) != 0 ||
      run({ips, "fit", "--data", (dir / "pairs.csv").string(), "--method", "plane", "--out",
           (dir / "model.json").string()},
          setup_log) != 0 ||
      run({ips, "sim", "render", "--scene", scene.string(), "--out", (dir / "frames").string(), "--frames",
           std::to_string(static_cast<int>(3 * o.fps)), "--fps", std::to_string(o.fps)},
          setup_log, std::chrono::minutes(10)) != 0) {
    std::fprintf(stderr, "bench_soak: setup failed, see %s\n", setup_log.c_str());
    return 1;
  }
  // Only the frames in which every camera sees a marker (black sees none in the first second
  // of this scene): a camera's silence in the stream is then a fault, never the scene.
  std::vector<std::string> keep;
  for (int k = 0; k < static_cast<int>(3 * o.fps); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "truth_%06d.json", k);
    const auto truth = nlohmann::json::parse(std::ifstream(dir / "frames" / name), nullptr, false);
    bool all = truth.is_object();
    for (int c = 0; all && c < kNCams; ++c) {
      bool seen = false;
      for (const auto& m : truth["markers"]) seen = seen || m["cameras"][kCams[c]].value("visible", false);
      all = seen;
    }
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "_%06d.jpg", k);
    if (all) keep.push_back(suffix);
  }
  if (keep.size() < 3) {
    std::fprintf(stderr, "bench_soak: fewer than 3 rendered frames show a marker to every camera\n");
    return 1;
  }
  std::printf("bench_soak: %zu of %d frames show a marker to every camera; those are served in a loop\n", keep.size(),
              static_cast<int>(3 * o.fps));
  std::string devices;
  for (int c = 0; c < kNCams; ++c) {
    const std::string name = kCams[c];
    fs::create_directories(dir / "frames" / name);
    for (const auto& e : fs::directory_iterator(dir / "frames"))
      for (const auto& suffix : keep)
        if (e.path().filename().string() == name + suffix)
          fs::rename(e.path(), dir / "frames" / name / e.path().filename());
    devices +=
        (c ? "," : "") + std::string("/dev/video-emu") + std::to_string(c) + "=" + (dir / (name + ".conf")).string();
  }
  auto control = [&](int c, const std::string& present, const std::string& corrupt_every) {
    write_control(dir / (std::string(kCams[c]) + ".conf"), {{"formats", "MJPG"},
                                                            {"sizes", "1920x1080"},
                                                            {"fps", std::to_string(o.fps)},
                                                            {"frames", (dir / "frames" / kCams[c]).string()},
                                                            {"card", std::string("Emulated ") + kCams[c]},
                                                            {"present", present},
                                                            {"corrupt_every", corrupt_every}});
  };
  for (int c = 0; c < kNCams; ++c) control(c, "1", "0");

  StreamMonitor monitor(kNCams, static_cast<std::int64_t>(o.gap * 1e9));
  const std::uint16_t second_port = free_port(SOCK_DGRAM), sub_port = free_port(SOCK_DGRAM),
                      web_port = free_port(SOCK_STREAM);
  int second_fd = udp_socket_on(second_port);
  const std::string status_socket = (dir / "status.sock").string();
  const fs::path config_path = dir / "ipsd.yaml";
  auto write_config = [&](const ConfigVariant& v) {
    std::ostringstream c;
    c << "cameras:\n";
    for (int k = 0; k < kNCams; ++k)
      c << "  - {name: " << kCams[k] << ", source: v4l2, device: /dev/video-emu" << k << ", fps: " << o.fps
        << ", intrinsics: " << IPS_SOURCE_DIR << "/calib_data/ou2023/intrinsics_" << kCams[k]
        << ".yaml, controls: {exposure: " << (k == 2 ? v.black_exposure : 0.004) << "}}\n";
    c << "markers:\n  ids:\n    1: {height: 0.15}\n    2: {height: 0.10}\n    3: {height: 0.0, edge_length: 0.15}\n"
      << "    4: {height: 0.05}\n";
    c << "model_file: " << (v.bad == "missing model" ? "missing_model.json" : "model.json") << "\n";
    if (v.bad == "unknown key")
      c << "fusion: {method: mean, windw: 0.02}\n";
    else if (v.bad == "bad value")
      c << "fusion: {method: mean, window: -1}\n";
    else
      c << "fusion: {method: mean, window: " << v.window << ", max_wait: 0.3}\n";
    c << "outputs:\n"
      << "  - {type: unicast, address: 127.0.0.1, port: " << monitor.port() << ", format: binary}\n"
      << "  - {type: unicast, address: 127.0.0.1, port: " << second_port << ", format: json}\n"
      << "  - {type: subscriptions, address: 127.0.0.1, port: " << sub_port << ", max_lease: 60}\n";
    c << "status: {interval: 60, socket: " << status_socket << "}\n";
    c << "web: {listen: \"127.0.0.1:" << web_port << "\"}\n";
    if (v.bad == "yaml syntax") c << "markers: [unclosed\n";
    std::ofstream(config_path) << c.str();
  };
  ConfigVariant good;
  write_config(good);

  NotifyListener notify((dir / "notify.sock").string(), static_cast<std::int64_t>(o.watchdog_s * 1e9));
  monitor.start();
  std::vector<std::string> command{o.ipsd.string(), "--config", config_path.string()};
  if (o.nice != 0) command.insert(command.begin(), {"/usr/bin/nice", "-n", std::to_string(o.nice)});
  const pid_t pid = spawn_with_env(command,
                                   {"LD_PRELOAD=" + o.emu.string(), "IPS_V4L2_EMU_DEVICES=" + devices,
                                    "NOTIFY_SOCKET=" + (dir / "notify.sock").string(),
                                    "WATCHDOG_USEC=" + std::to_string(static_cast<long long>(o.watchdog_s * 1e6))},
                                   log.string());
  if (pid <= 0) {
    std::fprintf(stderr, "bench_soak: cannot start %s\n", o.ipsd.c_str());
    return 1;
  }
  const ips::support::ChildGuard guard(pid);
  Report report(o.seconds, o.fps, o.period, o.gap, o.watchdog_s, kNCams);
  std::optional<int> early_exit;
  auto alive = [&] {
    if (!early_exit) early_exit = ips::support::wait_exit(pid, std::chrono::milliseconds(0));
    return !early_exit;
  };

  // Warm-up: every camera publishing.
  std::printf("bench_soak: ipsd pid %d, 3 emulated cameras at %.0f fps; warming up...\n", pid, o.fps);
  std::fflush(stdout);
  const std::size_t first = monitor.add_probe(now_ns(), std::vector<bool>(kNCams, true));
  const std::int64_t warm_limit = now_ns() + 120'000'000'000LL;
  while (alive() && !monitor.probe(first).done() && now_ns() < warm_limit) sleep_s(0.2);
  if (!monitor.probe(first).done()) {
    std::fprintf(stderr, "bench_soak: the cameras did not all publish within 120 s; see %s\n", log.c_str());
    return 1;
  }
  sleep_s(5);

  const std::int64_t t0 = now_ns();
  report.start(t0);
  // One sample: the process, the load, the stream, the daemon's own counters. The daemon's
  // per-camera counters restart with the camera threads (a reload changing the cameras), so
  // they are accumulated here: an increase adds the difference, a decrease the new value.
  std::mutex counters_mutex;
  std::vector<std::uint64_t> raw_drops(kNCams, 0), raw_corrupt(kNCams, 0), sum_drops(kNCams, 0), sum_corrupt(kNCams, 0);
  auto sample = [&] {
    Sample s;
    s.t_ns = now_ns();
    s.proc = proc_sample(pid);
    s.load = load_average_1m();
    s.datagrams = monitor.totals().datagrams;
    const auto doc = nlohmann::json::parse(ips::support::read_unix_socket(status_socket), nullptr, false);
    std::lock_guard lock(counters_mutex);
    // Walked by hand: json::value() on a const document trips GCC's -Wnull-dereference.
    if (doc.is_object())
      if (const auto cams = doc.find("cameras"); cams != doc.end() && cams->is_array())
        for (std::size_t k = 0; k < cams->size() && k < raw_drops.size(); ++k)
          for (auto [key, raw, sum] : {std::tuple{"drops", &raw_drops[k], &sum_drops[k]},
                                       std::tuple{"corrupt", &raw_corrupt[k], &sum_corrupt[k]}})
            if (const auto v = (*cams)[k].find(key); v != (*cams)[k].end() && v->is_number_unsigned()) {
              const auto now = v->get<std::uint64_t>();
              *sum += now >= *raw ? now - *raw : now;
              *raw = now;
            }
    s.camera_drops = sum_drops;
    for (int k = 0; k < kNCams; ++k)
      s.drops += sum_drops[static_cast<std::size_t>(k)], s.corrupt += sum_corrupt[static_cast<std::size_t>(k)];
    return s;
  };
  std::atomic<bool> sampling{true};
  std::thread sampler([&] {
    for (std::int64_t next = t0; sampling; next += 10'000'000'000LL) {
      while (sampling && now_ns() < next) sleep_s(0.1);
      if (!sampling) break;
      report.add_sample(sample());
    }
  });

  std::mt19937 rng(20261123);
  int unplug_next = 0, corrupt_next = 1, bad_next = 0;
  const char* const bad_kinds[] = {"yaml syntax", "unknown key", "missing model", "bad value"};
  const char* const kinds[] = {"unplug", "corrupt", "hup-good", "garbage", "unplug", "hup-bad", "listener", "hup-cams"};
  const std::int64_t end = t0 + static_cast<std::int64_t>(o.seconds * 1e9);
  for (int slot = 0; alive(); ++slot) {
    const std::int64_t slot_start = t0 + static_cast<std::int64_t>((slot + 0.5) * o.period * 1e9);
    while (alive() && now_ns() < std::min(slot_start, end)) sleep_s(0.1);
    if (!alive() || now_ns() >= end) break;
    Fault f;
    f.kind = kinds[slot % 8];
    f.start_ns = now_ns();
    f.excused.assign(kNCams, false);
    if (f.kind == "unplug") {
      const int c = unplug_next++ % kNCams;
      f.detail = kCams[c];
      f.excused[static_cast<std::size_t>(c)] = true;
      const int back_before = count_lines(log, std::string(kCams[c]) + ": ");
      control(c, "0", "0");
      sleep_s(10);
      control(c, "1", "0");
      f.end_ns = now_ns();
      f.check = wait_log(log, std::string(kCams[c]) + ": ", back_before, 20) ? "state changes logged" : "NO log line";
    } else if (f.kind == "corrupt") {
      const int c = corrupt_next++ % kNCams;
      f.detail = std::string(kCams[c]) + ", every 3rd frame for 15 s";
      const Sample before = sample();
      control(c, "1", "3");
      sleep_s(15);
      control(c, "1", "0");
      f.end_ns = now_ns();
      const Sample after = sample();
      f.check = after.corrupt > before.corrupt
                    ? "daemon counted " + std::to_string(after.corrupt - before.corrupt) + " corrupt frames"
                    : "NO corrupt frame counted";
    } else if (f.kind == "hup-good" || f.kind == "hup-cams" || f.kind == "hup-bad") {
      ConfigVariant v = good;
      std::string expect;
      if (f.kind == "hup-good") {
        good.window = good.window == 0.02 ? 0.025 : 0.02;
        v = good;
        f.detail = "fusion.window " + std::to_string(v.window).substr(0, 5);
        expect = "reload: applied";
      } else if (f.kind == "hup-cams") {
        good.black_exposure = good.black_exposure == 0.004 ? 0.005 : 0.004;
        v = good;
        f.detail = "black exposure " + std::to_string(v.black_exposure).substr(0, 5);
        for (int c = 0; c < kNCams; ++c) f.excused[static_cast<std::size_t>(c)] = true;
        expect = "the cameras changed";
      } else {
        v.bad = bad_kinds[bad_next++ % 4];
        f.detail = v.bad;
        expect = "reload refused";
      }
      const int before = count_lines(log, expect);
      write_config(v);
      f.start_ns = now_ns();
      ::kill(pid, SIGHUP);
      f.end_ns = now_ns();
      f.check = wait_log(log, expect, before, 10) ? "logged '" + expect + "'" : "NO '" + expect + "' in the log";
      if (!v.bad.empty()) write_config(good);  // back to a good file for the next reload
    } else if (f.kind == "garbage") {
      const int udp = udp_garbage(sub_port, 2000, rng);
      const int web = stream_garbage([&] { return connect_tcp(web_port); }, 60, 10, 2000, true, rng);
      const int st = stream_garbage([&] { return connect_unix(status_socket); }, 60, 5, 1000, false, rng);
      f.end_ns = now_ns();
      f.detail = std::to_string(udp) + " datagrams to subscriptions, " + std::to_string(web) + " web connections, " +
                 std::to_string(st) + " status-socket connections";
      const int code = http_get_status(web_port, "/status.json");
      const auto doc = nlohmann::json::parse(ips::support::read_unix_socket(status_socket), nullptr, false);
      f.check =
          "web /status.json " + std::to_string(code) + ", status socket " + (doc.is_object() ? "JSON ok" : "NO JSON");
    } else if (f.kind == "listener") {
      const fs::path llog = dir / "listen.log";
      fs::remove(llog);
      const pid_t l = spawn_with_env(
          {ips, "listen", "--subscribe", "127.0.0.1:" + std::to_string(sub_port), "--lease", "10"}, {}, llog.string());
      const bool subscribed = wait_log(llog, "subscribed at", 0, 10);
      sleep_s(3);
      ::kill(l, SIGKILL);
      (void)ips::support::wait_exit(l, std::chrono::seconds(5));
      ::close(second_fd);  // the second output's listener goes away too
      second_fd = -1;
      sleep_s(15);
      f.end_ns = now_ns();
      second_fd = udp_socket_on(second_port);
      const bool again = second_fd >= 0 && received_within(second_fd, 5);
      f.detail = std::string("subscriber ") + (subscribed ? "subscribed, then SIGKILLed" : "NEVER subscribed") +
                 "; second unicast listener closed 15 s";
      f.check = again ? "second listener receives again" : "second listener receives NOTHING";
    }
    f.probe = monitor.add_probe(f.end_ns, std::vector<bool>(kNCams, true));
    report.add_fault(f);
    std::printf("[%6.0f s] %-9s %s (%s)  load %.2f\n", 1e-9 * static_cast<double>(f.start_ns - t0), f.kind.c_str(),
                f.detail.c_str(), f.check.c_str(), load_average_1m());
    std::fflush(stdout);
    if (second_fd >= 0) received_within(second_fd, 0);  // keep its buffer empty
  }
  while (alive() && now_ns() < end) sleep_s(0.2);
  // The last fault's recovery is measured even if it runs past the end (at most 60 s more).
  const std::int64_t grace = now_ns() + 60'000'000'000LL;
  while (alive() && now_ns() < grace && !report.faults().empty() && !monitor.probe(report.faults().back().probe).done())
    sleep_s(0.2);
  sampling = false;
  sampler.join();
  const std::int64_t t_end = now_ns();
  report.set_nice(o.nice, process_nice(pid));
  const auto final_status = nlohmann::json::parse(ips::support::read_unix_socket(status_socket), nullptr, false);
  report.add_sample(sample());
  std::optional<int> exit_status = early_exit;
  if (!early_exit) {
    ::kill(pid, SIGTERM);
    exit_status = ips::support::wait_exit(pid, std::chrono::seconds(30));
  }
  monitor.stop();
  if (second_fd >= 0) ::close(second_fd);
  for (std::size_t i = 0; i < report.faults().size(); ++i)
    report.set_recovery(i, monitor.probe(report.faults()[i].probe));
  report.finish(t_end, early_exit.has_value(), exit_status, monitor.totals(), monitor.gaps(), notify.figures(),
                final_status, count_lines(log, "AddressSanitizer") + count_lines(log, "runtime error"));
  report.write(fs::absolute(o.out));
  std::printf("%s", report.text().c_str());
  return report.passed() ? 0 : 1;
}
