// Status of the running daemon: per-camera rates sampled every second by the main thread,
// rendered as log lines, as the systemd STATUS= text, and as the JSON `ips status` reads
// from the unix socket.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline.h"

namespace ipsd {

struct CameraRates {
  std::string name;
  std::string source;
  std::string state;  ///< "open" | "down" | "starting"
  std::string last_error;
  double fps = 0;        ///< frames processed per second over the last sample period
  double detect_ms = 0;  ///< mean detect+locate+map time per frame, ms
  double queue_ms = 0;   ///< mean wait from delivery until a worker started the frame, ms
  double markers = 0;    ///< mean markers per frame
  std::uint64_t frames = 0, drops = 0, corrupt = 0, failures = 0, no_height = 0;
  bool restart_markers = false;       ///< frames carry restart markers (region decodes cut at them)
  std::uint64_t restart_damaged = 0;  ///< frames whose restart markers were misplaced
  std::uint64_t over_budget = 0;      ///< frames dropped unprocessed after waiting a whole budget (in drops)
  std::uint64_t body_rejected = 0;    ///< body markers whose view gave no body observation (docs/bodies.md)
  /// A camera on a robot (docs/inside-out.md): frames that placed the robot, frames with
  /// markers that did not, ceiling markers left out as outliers.
  std::uint64_t robot_poses = 0, robot_unplaced = 0, ceiling_outliers = 0;
  bool on_robot = false;
  std::uint64_t detect_ns_total = 0, queue_ns_total = 0, markers_total = 0;  ///< since start
  std::uint64_t acquire_ns_total = 0;  ///< searches for new markers after publishing, since start
};

/// Samples counters at each call and turns the differences into rates.
class RateSampler {
 public:
  void sample(const std::vector<CameraStats*>& cameras, const std::vector<std::string>& names,
              const FusionStats& fusion, std::int64_t now_ns);
  const std::vector<CameraRates>& cameras() const { return rates_; }
  double updates_per_s() const { return updates_per_s_; }

 private:
  struct Previous {
    std::uint64_t frames = 0, detect_ns = 0, markers = 0, queue_ns = 0;
  };
  std::vector<Previous> previous_;
  std::uint64_t previous_updates_ = 0;
  std::int64_t previous_ns_ = 0;
  std::vector<CameraRates> rates_;
  double updates_per_s_ = 0;
};

/// One line per camera plus one for fusion/outputs.
std::vector<std::string> status_lines(const RateSampler& rates, FusionStats& fusion, std::uint64_t queue_drops);
/// "red 29.9 fps, white 30.0 fps, black down" for sd_notify STATUS=.
std::string systemd_status(const RateSampler& rates);
/// The JSON document served on the status socket (docs/daemon.md documents its fields).
nlohmann::json status_json(const RateSampler& rates, FusionStats& fusion, std::uint64_t queue_drops,
                           const Runtime& runtime, std::int64_t started_mono_ns, std::int64_t synthetic_epoch_mono_ns);

/// A listening unix stream socket: every client that connects gets one JSON document and EOF.
class StatusSocket {
 public:
  /// The socket file's mode: owner and group may connect (members of group ipsd under systemd).
  static constexpr unsigned kSocketMode = 0660;
  StatusSocket() = default;
  /// Creates `path` (replacing a stale socket file). Throws ips::InputError naming status.socket.
  explicit StatusSocket(const std::string& path);
  ~StatusSocket();
  StatusSocket(StatusSocket&& o) noexcept;
  StatusSocket& operator=(StatusSocket&& o) noexcept;
  int fd() const { return fd_; }
  const std::string& path() const { return path_; }
  /// Accepts one pending client and writes `text` (non-blocking; a slow client gets what fits).
  void serve(const std::string& text);

 private:
  int fd_ = -1;
  std::string path_;
};

}  // namespace ipsd
