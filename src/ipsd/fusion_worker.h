// The fusion + publish thread: groups the cameras' per-frame batches by capture time, fuses
// each marker, optionally Kalman-filters it, and sends one update per frame set.
#pragma once

#include <atomic>
#include <optional>
#include <thread>
#include <vector>

#include "ips/kalman.h"
#include "pipeline.h"

namespace ipsd {

class FusionWorker {
 public:
  FusionWorker(RuntimeHolder& runtime, ObservationQueue& queue, std::vector<CameraStats*> cameras, FusionStats& stats);
  ~FusionWorker();
  void start();
  void request_stop() { stop_ = true; }
  void join();

 private:
  void run();
  void publish(std::vector<ips::FrameObservations>& set, const Runtime& rt);

  RuntimeHolder& runtime_;
  ObservationQueue& queue_;
  std::vector<CameraStats*> cameras_;
  FusionStats& stats_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::uint32_t update_ = 0;
  std::optional<ips::MarkerTracker> tracker_;  // engaged when fusion.kalman is on
};

}  // namespace ipsd
