// The pool of workers that process the cameras' frames: each takes the oldest waiting frame
// (ips::FrameScheduler) and runs that camera's process() on it. One worker per core by default
// (processing.workers), instead of one thread per camera competing for the cores with no notion
// of which frame is oldest.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "camera_worker.h"
#include "ips/capture/frame_scheduler.h"

namespace ipsd {

class FrameWorkers {
 public:
  /// `cameras[i]` processes camera i's frames; `count` >= 1 threads.
  FrameWorkers(ips::FrameScheduler& scheduler, std::vector<CameraWorker*> cameras, int count);
  ~FrameWorkers();

  void start();
  void request_stop() { stop_ = true; }
  void join();
  int count() const { return static_cast<int>(heartbeats_.size()); }
  /// CLOCK_MONOTONIC of worker k's last loop iteration (the watchdog's view of it).
  std::int64_t heartbeat_ns(int k) const { return heartbeats_[static_cast<std::size_t>(k)]->load(); }

 private:
  void run(int k);

  ips::FrameScheduler& scheduler_;
  std::vector<CameraWorker*> cameras_;
  std::vector<std::unique_ptr<std::atomic<std::int64_t>>> heartbeats_;
  std::vector<std::thread> threads_;
  std::atomic<bool> stop_{false};
};

}  // namespace ipsd
