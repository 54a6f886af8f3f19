// The fusion + publish thread: feeds each camera frame's batch to the asynchronous fusion
// (ips/fusion/track_fusion.h) and sends one update per camera frame at once (or, with
// fusion.output_rate, one update per tick with every marker predicted to the tick).
#pragma once

#include <atomic>
#include <optional>
#include <thread>
#include <vector>

#include "ips/body/body_track.h"
#include "ips/fusion/fixed_markers.h"
#include "ips/fusion/track_fusion.h"
#include "ips/web/web.h"
#include "latest_states.h"
#include "pipeline.h"

namespace ipsd {

class FusionWorker {
 public:
  FusionWorker(RuntimeHolder& runtime, ObservationQueue& queue, std::vector<CameraStats*> cameras, FusionStats& stats);
  ~FusionWorker();
  /// The web view gets a copy of every update (before start(); nullptr = none).
  void set_web(ips::WebServer* web) { web_ = web; }
  /// Every camera batch is also checked against the fixed markers (before start(); owned by the caller).
  void set_fixed_monitor(ips::FixedMarkerMonitor* monitor) { fixed_ = monitor; }
  /// Where every published marker state is kept for the range input (mobile anchors).
  void set_latest_states(LatestStates* latest) { latest_ = latest; }
  void start();
  void request_stop() { stop_ = true; }
  void join();

 private:
  void run();
  void publish(const std::vector<ips::FusedMarker>& states, const std::vector<ips::FusedBody>& bodies,
               std::int64_t t_mono_ns, std::int64_t t_real_ns, std::int64_t t_delivered_ns, const Runtime& rt);

  RuntimeHolder& runtime_;
  ObservationQueue& queue_;
  std::vector<CameraStats*> cameras_;
  FusionStats& stats_;
  ips::WebServer* web_ = nullptr;
  ips::FixedMarkerMonitor* fixed_ = nullptr;
  LatestStates* latest_ = nullptr;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::uint32_t update_ = 0;
};

}  // namespace ipsd
