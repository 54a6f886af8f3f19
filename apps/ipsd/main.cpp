// ipsd: the real-time indoor positioning daemon (cameras -> markers -> world -> UDP).
// Exit status: 0 clean stop, 1 run-time failure (a required camera absent at start, ...),
// 2 bad configuration / model / intrinsics (systemd: RestartPreventExitStatus=2).
#include <malloc.h>

#include <cstdio>
#include <cstdlib>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "daemon.h"
#include "ips/config/config.h"
#include "ips/core/error.h"
#include "ips/core/image_buffer_pool.h"
#include "signals.h"

int main(int argc, char** argv) {
  // Image-sized buffers (decoded frames, regions, OpenCV's detector scratch) come from one
  // bounded pool and go back to it, frame after frame: the steady state asks the heap for none
  // (include/ips/core/image_buffer_pool.h).
  ips::install_image_buffer_pool();
  // What still goes to the heap per frame is OpenCV's contour storage (64-128 KiB blocks) and
  // small objects. Keep freed memory in the heap rather than handing it back to the kernel only
  // to fault it in again on the next frame (daemon.cpp trims once a minute).
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  // One heap (arena) for every thread, not glibc's default of up to 8 per core: each arena keeps
  // its own high-water mark resident, and a camera thread restarted by a reload or a replug takes
  // whichever arena is free, so with many arenas resident memory climbs in steps at every fault.
  // Measured with the pool and glibc's defaults: the 30-minute soak climbed 38 MiB/h; with one
  // arena it stays flat (docs/performance.md, "Memory"). With image buffers pooled, the shared
  // heap lock guards only small allocations.
  mallopt(M_ARENA_MAX, 1);
  CLI::App app{"ipsd: indoor positioning daemon (overhead cameras -> ArUco markers -> world positions over UDP)"};
  app.set_version_flag("--version", std::string("ipsd ") + IPS_VERSION);
  std::string config = "/etc/ipsd/ipsd.yaml";
  bool check = false;
  std::string log_level;
  app.add_option("-c,--config", config, "configuration file (YAML)")->capture_default_str();
  app.add_flag("--check", check, "load and validate the configuration, model and intrinsics, then exit (0 = good)");
  app.add_option("--log-level", log_level, "override logging.level: trace|debug|info|warn|error");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? 0 : 2;
  }
  // Under systemd the journal adds time and unit; on a terminal show the time ourselves.
  spdlog::set_pattern(std::getenv("JOURNAL_STREAM") ? "%^%l%$: %v" : "[%H:%M:%S.%e] %^%l%$: %v");
  try {
    // Before any thread exists (the Daemon's constructor starts the outputs' threads: DDS,
    // subscriptions), so that every thread inherits the mask and SIGTERM/SIGHUP reach only the
    // daemon's signalfd (signals.h). --check starts no thread and stays interruptible.
    if (!check) ipsd::block_daemon_signals();
    ipsd::Daemon daemon(config, check ? ipsd::Daemon::Mode::kCheck : ipsd::Daemon::Mode::kRun);
    if (!log_level.empty()) spdlog::set_level(spdlog::level::from_str(log_level));
    if (check) {
      daemon.check_sources();
      std::printf("ipsd: %s is valid\n", config.c_str());
      return 0;
    }
    return daemon.run();
  } catch (const ips::InputError& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
