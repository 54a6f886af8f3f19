// The daemon: starts the camera and fusion threads from a configuration, then runs the main
// thread's loop (signals via signalfd, status lines, the status socket, systemd notify and
// the watchdog fed from the threads' own heartbeats).
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "camera_worker.h"
#include "frame_workers.h"
#include "fusion_worker.h"
#include "ips/web/web.h"
#include "pipeline.h"
#include "range_link.h"
#include "status.h"

namespace ipsd {

class Daemon {
 public:
  /// kCheck (`ipsd --check`) validates without taking what a running daemon holds: no status
  /// socket (it would replace a running daemon's socket file), no subscriptions port, no DDS
  /// participant (see ips::Publisher's validate_only).
  enum class Mode { kRun, kCheck };
  /// Loads and checks everything; throws ips::InputError (exit 2) for a bad configuration,
  /// model file, intrinsics or output.
  explicit Daemon(std::filesystem::path config_path, Mode mode = Mode::kRun);
  ~Daemon();

  /// Opens the cameras, starts the threads, serves until SIGTERM/SIGINT. Returns the exit
  /// status: 0 after a clean stop, 1 if a `required: true` camera cannot be opened at start.
  int run();

  /// What --check adds to the constructor's checks: every camera's source can be created
  /// (scene and scene camera exist, V4L2/file options valid). Opens nothing.
  void check_sources() const { (void)make_factories(runtime_.get()->config); }

 private:
  struct Pipeline;
  /// One source factory per camera; throws ips::InputError for a camera it cannot serve.
  std::vector<ips::SourceFactory> make_factories(const ips::DaemonConfig& config) const;
  bool start_pipeline(std::shared_ptr<const Runtime> runtime, std::vector<ips::SourceFactory> factories, bool at_start);
  void stop_pipeline();
  void reload();
  void tick(std::int64_t now);
  /// The status document of `ips status --json` and /status.json (sampled now).
  nlohmann::json status_document();

  std::filesystem::path config_path_;
  RuntimeHolder runtime_;
  std::unique_ptr<Pipeline> pipeline_;
  std::optional<StatusSocket> status_socket_;
  std::unique_ptr<ips::WebServer> web_;  // web view (web.listen), started by run()
  LatestStates latest_states_;           // published states, for the range input's mobile anchors
  std::unique_ptr<RangeLink> ranges_;    // ranging: (absent = nullptr); outlives camera restarts
  std::int64_t started_ns_ = 0;
  std::int64_t synthetic_epoch_ns_ = 0;
  std::int64_t next_sample_ns_ = 0;
  std::int64_t next_status_log_ns_ = 0;
  std::int64_t next_watchdog_ns_ = 0;
  std::int64_t next_trim_ns_ = 0;  // malloc_trim period (daemon.cpp, kTrimNs)
  std::uint64_t watchdog_usec_ = 0;
  bool stalled_ = false;
};

}  // namespace ipsd
