// One camera: its capture thread only dequeues frames (always the newest) and hands them to the
// frame scheduler; the workers (frame_workers.h) call process() on them, one frame of a camera at
// a time: detect -> camera coordinates -> that camera's mapper. Results go to the fusion thread's
// queue.
#pragma once

#include <atomic>
#include <memory>
#include <thread>

#include "ips/capture/frame_scheduler.h"
#include "ips/capture/source_supervisor.h"
#include "ips/detect/detector.h"
#include "ips/detect/tracked_frame_detector.h"
#include "ips/web/web.h"
#include "pipeline.h"

namespace ipsd {

class CameraWorker {
 public:
  CameraWorker(const ips::CameraConfig& config, ips::SourceFactory factory, RuntimeHolder& runtime,
               ips::FrameScheduler& scheduler, ObservationQueue& queue, CameraStats& stats);
  ~CameraWorker();

  /// First open attempt, before the thread starts (start-up checks `required`).
  bool open_first();
  const ips::SourceSupervisor& supervisor() const { return supervisor_; }

  /// The web view's hand-over point (before start(); none without a web view).
  void set_tap(std::shared_ptr<ips::FrameTap> tap) { tap_ = std::move(tap); }
  void start();
  void request_stop() { stop_ = true; }
  void join();

  /// A worker's turn with this camera's frame (never two at once: the scheduler sees to it).
  void process(ips::Frame& frame);

 private:
  void run();
  /// One detected marker of `frame` into `batch`: a view of its body, or its world position.
  void observe(const Runtime& rt, const ips::MarkerDetection& d, const ips::Frame& frame, CameraBatch& batch);
  /// A camera on a robot (cameras[].on_robot): the frame's ceiling markers -> the robot's pose,
  /// one observation of its marker id (source inside-out, with its covariance).
  void place_robot(const Runtime& rt, const ips::CeilingMap& map, const std::vector<ips::MarkerDetection>& detections,
                   const ips::Frame& frame, CameraBatch& batch);

  ips::CameraConfig config_;
  ips::SourceSupervisor supervisor_;
  RuntimeHolder& runtime_;
  ips::FrameScheduler& scheduler_;
  ObservationQueue& queue_;
  CameraStats& stats_;
  std::shared_ptr<ips::FrameTap> tap_;  // web view: a frame is copied only when a page asked
  // Decode (only what tracking needs: the source hands JPEG frames over undecoded) + detect;
  // used by one worker at a time, rebuilt when a reload changes detection or tracking.
  std::unique_ptr<ips::TrackedFrameDetector> detector_;
  std::atomic<bool> reset_detector_{false};  // the capture thread reopened the source
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace ipsd
