// What the daemon's threads share: the immutable runtime snapshot (swapped on SIGHUP), the
// queue from the camera threads to the fusion thread, and the per-thread counters that the
// main thread reads for status lines, `ips status` and the watchdog.
#pragma once

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "ips/body/body_estimate.h"
#include "ips/config/config.h"
#include "ips/fusion/fusion.h"
#include "ips/geometry/camera_model.h"
#include "ips/insideout/ceiling_map.h"
#include "ips/mapping/model_file.h"
#include "ips/output/publisher.h"

namespace ipsd {

/// Everything a reload may replace. Immutable once published (the publisher is used by the
/// fusion thread alone).
struct Runtime {
  ips::DaemonConfig config;
  std::shared_ptr<const ips::ModelSet> models;
  std::vector<ips::CameraModel> intrinsics;  ///< by camera index
  std::vector<const ips::Mapper*> mappers;   ///< by camera index, owned by *models
  ips::MarkerSizes sizes;
  const ips::FusionMethod* fusion = nullptr;
  std::shared_ptr<ips::Publisher> publisher;
  /// bodies: the camera threads' marker -> body observation step (const, shared); null
  /// without bodies. The fusion thread fuses the bodies (ips/body/body_track.h).
  std::shared_ptr<const ips::BodyEstimator> bodies;
  /// By camera index: the ceiling map of a camera that rides on a robot (cameras[].on_robot),
  /// null for an overhead camera (whose mapper is then in `mappers`).
  std::vector<std::shared_ptr<const ips::CeilingMap>> ceiling_maps;
};

/// What a camera thread hands the fusion thread per frame: the plain markers (as
/// ips::FrameObservations) and the views of rigid bodies (their markers are not in the former).
/// A fix of a ranging tag carried by a body (ranging.tags[].body): BodyTrack::add_fix.
struct BodyFix {
  std::string body;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< the tag in the body's frame
  ips::WorldObservation fix;
};

struct CameraBatch : ips::FrameObservations {
  std::vector<ips::BodyObservation> bodies;
  std::vector<BodyFix> body_fixes;  ///< the range input's (camera_index -1)
};

/// Loads the model file, the intrinsics, resolves the fusion method and opens the outputs
/// (reusing `previous`'s publisher when the outputs did not change, so sequence numbers
/// continue). Throws ips::InputError naming the key/file; nothing is half-applied.
/// `validate_only` (ipsd --check): see ips::Publisher.
std::shared_ptr<const Runtime> build_runtime(const ips::DaemonConfig& config, const Runtime* previous,
                                             bool validate_only = false);

class RuntimeHolder {
 public:
  std::shared_ptr<const Runtime> get() const {
    std::lock_guard lock(mutex_);
    return runtime_;
  }
  void set(std::shared_ptr<const Runtime> r) {
    std::lock_guard lock(mutex_);
    runtime_ = std::move(r);
  }

 private:
  mutable std::mutex mutex_;
  std::shared_ptr<const Runtime> runtime_;
};

/// Camera threads -> fusion thread. Bounded: when the fusion thread falls behind, the oldest
/// batch is dropped (counted) so that the newest positions always go out.
class ObservationQueue {
 public:
  explicit ObservationQueue(std::size_t capacity = 64) : capacity_(capacity) {}
  void push(CameraBatch batch);
  /// Waits up to `timeout_ns` for a batch. False on timeout or after close().
  bool pop(CameraBatch& out, std::int64_t timeout_ns);
  void close();
  std::uint64_t dropped() const { return dropped_.load(); }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<CameraBatch> queue_;
  std::size_t capacity_;
  bool closed_ = false;
  std::atomic<std::uint64_t> dropped_{0};
};

enum class CameraState : int { kStarting = 0, kOpen = 1, kDown = 2 };

/// Counters of one camera thread (written by it, read by the main thread).
struct CameraStats {
  std::atomic<std::uint64_t> frames{0};  ///< frames processed
  /// frames not processed: skipped or replaced to stay on the newest, over budget, source sequence gaps
  std::atomic<std::uint64_t> drops{0};
  std::atomic<std::uint64_t> corrupt{0};     ///< undecodable frames
  std::atomic<std::uint64_t> failures{0};    ///< source failures (open errors, unplug, end)
  std::atomic<std::uint64_t> detect_ns{0};   ///< sum of detect+locate+map time
  std::atomic<std::uint64_t> acquire_ns{0};  ///< sum of the searches for new markers after publishing
  std::atomic<std::uint64_t> queue_ns{0};    ///< sum of the waits delivery -> a worker starts the frame
  std::atomic<bool> restart_markers{false};  ///< the last region-decoded frame was cut at restart markers
  std::atomic<std::uint64_t> restart_damaged{
      0};                                       ///< frames whose restart markers were misplaced (decoded the slow way)
  std::atomic<std::uint64_t> over_budget{0};    ///< frames dropped unprocessed: they waited a whole budget (in drops)
  std::atomic<std::uint64_t> markers{0};        ///< sum of markers mapped
  std::atomic<std::uint64_t> no_height{0};      ///< markers dropped: the mapper needs a height, none configured
  std::atomic<std::uint64_t> body_rejected{0};  ///< body markers whose view gave no body observation
  /// on_robot cameras: frames that placed the robot, and frames with markers that did not
  /// (no marker of the map, or none consistent); ceiling markers left out as outliers.
  std::atomic<std::uint64_t> robot_poses{0};
  std::atomic<std::uint64_t> robot_unplaced{0};
  std::atomic<std::uint64_t> ceiling_outliers{0};
  std::atomic<std::int64_t> heartbeat_ns{0};  ///< CLOCK_MONOTONIC of the last loop iteration
  std::atomic<int> state{0};                  ///< CameraState
  std::mutex error_mutex;
  std::string last_error;
  std::string source;  ///< description of the source
};

/// Latency samples of one status interval: the fusion thread adds, the main thread rotates
/// at each status interval and reads the last complete interval's percentiles.
class LatencyWindow {
 public:
  struct Percentiles {
    double p50_ms = NAN, p99_ms = NAN;
    std::size_t samples = 0;
  };
  void add(std::int64_t processing_ns, std::int64_t capture_ns);
  /// Closes the current interval (its samples become the reported ones) and starts a new one.
  void rotate();
  /// Of the last closed interval; before the first rotate(), of the samples so far.
  Percentiles processing() const;
  Percentiles capture() const;

 private:
  static Percentiles of(std::vector<std::int64_t> v);
  static constexpr std::size_t kMaxSamples = 100000;  // bounds memory for long intervals
  mutable std::mutex mutex_;
  std::vector<std::int64_t> processing_, capture_;            // current interval
  std::vector<std::int64_t> last_processing_, last_capture_;  // last closed interval
  bool rotated_ = false;
};

/// Counters of the fusion thread.
struct FusionStats {
  std::atomic<std::uint64_t> updates{0};
  std::atomic<std::int64_t> heartbeat_ns{0};
  std::atomic<std::int64_t> last_latency_ns{0};    ///< capture -> sendto of the last datagram
  std::atomic<std::uint64_t> late{0};              ///< observations that arrived after a newer output of their marker
  std::atomic<std::uint64_t> too_old{0};           ///< observations dropped: older than fusion.history
  std::atomic<std::uint64_t> held_for_cameras{0};  ///< range fixes merged, not published: a camera had the marker
  std::atomic<double> camera_hold_s{0.0};          ///< fusion.camera_hold as applied (longer where frames are late)
  LatencyWindow latency;                           ///< delivered -> sendto and capture -> sendto
  std::mutex outputs_mutex;
  std::vector<ips::OutputStats> outputs;
};

}  // namespace ipsd
