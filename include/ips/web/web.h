// The web view: one embedded HTTP server (CivetWeb) serving the page (assets embedded in the
// binary), /status.json, /layout.json, a Server-Sent-Events stream of fused positions
// (/events) and each camera's latest frame with its detections (/camera/<name>.jpg|.json).
// Read-only (GET and HEAD). Nothing here blocks the pipeline: positions are copied into a bounded inbox and
// sent by the server's own fan-out thread into bounded per-client queues (overflow drops the
// oldest message, counted); camera frames are handed over by the camera thread only when a
// page asked for one (FrameTap::wanted) and are downscaled, drawn and encoded on the HTTP
// thread that serves them.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "ips/core/observation.h"
#include "ips/output/packet_codec.h"
#include "ips/web/web_settings.h"

namespace ips {

class CameraModel;
class Mapper;

/// A camera frame and what the daemon detected in it, as handed over by the camera thread.
struct FrameSnapshot {
  std::uint64_t sequence = 0;
  std::int64_t t_mono_ns = 0;
  cv::Mat gray;  ///< full resolution, owned by the snapshot (a copy)
  std::vector<MarkerDetection> detections;
};

/// Hand-over point between one camera thread and the web server. The camera thread checks
/// wanted() after each frame (one relaxed atomic load) and calls offer() only when it is set.
class FrameTap {
 public:
  bool wanted() const { return wanted_.load(std::memory_order_relaxed); }
  /// Camera thread: copies `gray` (the source may reuse its buffer) and wakes the waiter.
  void offer(const cv::Mat& gray, const std::vector<MarkerDetection>& detections, std::uint64_t sequence,
             std::int64_t t_mono_ns);
  /// Web thread: asks for the next frame and waits up to `timeout_ns` for it (nullptr if
  /// none came: camera down or stopped).
  std::shared_ptr<const FrameSnapshot> request(std::int64_t timeout_ns);
  std::uint64_t handed_over() const { return handed_over_.load(); }

 private:
  std::atomic<bool> wanted_{false};
  std::atomic<std::uint64_t> handed_over_{0};
  std::mutex mutex_;
  std::condition_variable cv_;
  std::shared_ptr<const FrameSnapshot> latest_;
  std::uint64_t generation_ = 0;
};

/// Where a request goes (pure function of method and path; tested on its own). GET and HEAD
/// are served; any other method is kBadMethod.
struct Route {
  enum class Kind {
    kPage,
    kAsset,
    kStatus,
    kLayout,
    kEvents,
    kCameraJpeg,
    kCameraJson,
    kNotFound,
    kBadMethod,
    kBadRequest
  };
  Kind kind = Kind::kNotFound;
  std::string name;   ///< asset file name or camera name
  bool head = false;  ///< HEAD: the GET answer's status and headers, no body
};
Route route_request(const std::string& method, const std::string& path);

/// An embedded static file (generated from src/web/assets/ at build time).
struct Asset {
  const char* name;
  const char* mime;
  const unsigned char* data;
  std::size_t size;
};
const Asset* find_asset(const std::string& name);

/// The floor footprint of a camera with a pose model: the image border's pixels cast through
/// the intrinsics and the mapper's world ray onto z = `height`, as a closed polygon (world
/// x, y). Rays that miss the floor or land further than `max_range` m from below the camera
/// are cut there. Empty when the mapper has no camera pose (world_ray() false).
std::vector<Eigen::Vector2d> camera_footprint(const CameraModel& intrinsics, const Mapper& mapper, double height = 0.0,
                                              double max_range = 6.0);

/// The camera view image: `snapshot` downscaled to at most `width` pixels wide, with the
/// detections' outlines and ids (green) drawn; `info` gets their geometry in JPEG pixels and
/// OpenCV's rejected candidate squares (searched on the downscaled image; not drawn: the page
/// draws them when asked).
struct CameraView {
  std::string jpeg;        ///< with overlay
  std::string plain_jpeg;  ///< the same downscaled frame without overlay
  std::string info;        ///< JSON: camera, sequence, t_mono_ns, width, height, scale, detections, rejected
};
CameraView render_camera_view(const std::string& camera, const FrameSnapshot& snapshot, int width,
                              const std::string& dictionary);

struct WebCounters {
  std::uint64_t clients = 0;        ///< live streams now
  std::uint64_t clients_total = 0;  ///< streams opened since start
  std::uint64_t refused = 0;        ///< streams refused (max_clients or max_per_address reached)
  std::uint64_t messages = 0;       ///< stream messages sent
  std::uint64_t dropped = 0;        ///< stream messages dropped (a client's queue was full)
  std::uint64_t inbox_dropped = 0;  ///< fused updates dropped before the fan-out thread saw them
  std::uint64_t frames = 0;         ///< camera view images encoded
  std::uint64_t bad_requests = 0;   ///< 4xx answers (and our 503s)
  std::uint64_t limited = 0;        ///< requests refused with 503 because their address had max_per_address
};

class WebServer {
 public:
  /// Starts listening on config.host:config.port. Throws ips::InputError naming web.listen
  /// when the address cannot be bound.
  WebServer(const WebConfig& config, const std::string& dictionary);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  /// The cameras (by index) and their taps; the daemon passes each tap to its camera thread.
  /// Called again when a reload changes the cameras.
  std::vector<std::shared_ptr<FrameTap>> set_cameras(const std::vector<std::string>& names);
  /// /layout.json (floor, camera footprints, marker names), rebuilt by the daemon per runtime.
  void set_layout(std::string json);
  /// /status.json (the `ips status --json` document), refreshed by the daemon every second;
  /// also sent on the stream as a `status` event.
  void set_status(std::string json);
  /// Fusion thread: one fused update (copied into a bounded inbox; never blocks on clients).
  void publish(const Datagram& update);

  WebCounters counters() const;
  int port() const { return port_; }

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

}  // namespace ips
