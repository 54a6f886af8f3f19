#include "camera_worker.h"

#include <pthread.h>

#include <cmath>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"
#include "ips/detect/detector.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/insideout/localise.h"
#include "ips/insideout/on_robot.h"
#include "ips/mapping/to_world.h"

namespace ipsd {

namespace {
// How long one read may block: bounds the time to notice a stop request (SIGTERM -> exit
// within 2 s) and the heartbeat period of a camera that delivers nothing.
constexpr std::chrono::milliseconds kReadTimeout{100};
// At most this many queued frames are skipped per iteration to reach the newest one
// (a source that is always ready, such as an unpaced file, must not starve the detector).
constexpr int kMaxSkip = 8;
}  // namespace

CameraWorker::CameraWorker(const ips::CameraConfig& config, ips::SourceFactory factory, RuntimeHolder& runtime,
                           ips::FrameScheduler& scheduler, ObservationQueue& queue, CameraStats& stats)
    : config_(config),
      supervisor_(config.name, std::move(factory)),
      runtime_(runtime),
      scheduler_(scheduler),
      queue_(queue),
      stats_(stats) {
  // MJPEG frames arrive undecoded: process() decodes only the regions the tracker searches
  // (and a frame skipped to stay on the newest one is never decoded at all).
  supervisor_.set_defer_decode(true);
}

CameraWorker::~CameraWorker() {
  request_stop();
  join();
}

bool CameraWorker::open_first() {
  const bool ok = supervisor_.open();
  stats_.state = static_cast<int>(ok ? CameraState::kOpen : CameraState::kDown);
  stats_.failures = supervisor_.failures();
  std::lock_guard lock(stats_.error_mutex);
  stats_.last_error = supervisor_.last_error();
  stats_.source = supervisor_.describe();
  return ok;
}

void CameraWorker::start() {
  stats_.heartbeat_ns = ips::monotonic_ns();
  thread_ = std::thread([this] { run(); });
}

void CameraWorker::join() {
  if (thread_.joinable()) thread_.join();
}

void CameraWorker::run() {
  const std::string thread_name = ("cam:" + config_.name).substr(0, 15);  // visible in top -H
  pthread_setname_np(pthread_self(), thread_name.c_str());
  std::uint64_t last_sequence = 0;
  bool have_sequence = false;
  std::uint64_t reported_failures = supervisor_.failures();
  ips::Frame frame, newer;
  while (!stop_) {
    stats_.heartbeat_ns = ips::monotonic_ns();
    auto status = supervisor_.read(frame, kReadTimeout);
    if (supervisor_.failures() != reported_failures) {
      reported_failures = supervisor_.failures();
      stats_.failures = reported_failures;
      have_sequence = false;   // a reopened source restarts its counter
      reset_detector_ = true;  // and may show anything: search in full (at process())
      std::lock_guard lock(stats_.error_mutex);
      stats_.last_error = supervisor_.last_error();
    }
    stats_.state = static_cast<int>(supervisor_.state() == ips::SourceSupervisor::State::kOpen ? CameraState::kOpen
                                                                                               : CameraState::kDown);
    if (status == ips::FrameSource::ReadStatus::kCorrupt) {
      ++stats_.corrupt;
      continue;
    }
    if (status != ips::FrameSource::ReadStatus::kFrame) continue;
    if (frame.t_delivered_ns == 0) frame.t_delivered_ns = ips::monotonic_ns();
    // Newest frame only: while the frame in hand is more than 1.5 frame periods old (a backlog
    // in the driver's queue, or a simulated camera behind schedule), take the next one that
    // is already waiting, counting what is skipped. A fresh frame is never read past: for a
    // source that produces frames on demand that would cost a frame per skip.
    const auto stale_ns = static_cast<std::int64_t>(1.5e9 / config_.fps);
    for (int i = 0; i < kMaxSkip && ips::monotonic_ns() - frame.t_mono_ns > stale_ns; ++i) {
      const auto more = supervisor_.read(newer, std::chrono::milliseconds(0));
      if (more == ips::FrameSource::ReadStatus::kCorrupt) {
        ++stats_.corrupt;
        continue;
      }
      if (more != ips::FrameSource::ReadStatus::kFrame) break;
      if (newer.t_delivered_ns == 0) newer.t_delivered_ns = ips::monotonic_ns();
      std::swap(frame, newer);
    }
    if (have_sequence && frame.sequence > last_sequence + 1) stats_.drops += frame.sequence - last_sequence - 1;
    have_sequence = true;
    last_sequence = frame.sequence;
    // To the workers; the frame handed back (a spent one of this camera) keeps its buffers.
    bool superseded = false;
    frame = scheduler_.submit(config_.index, std::move(frame), &superseded);
    if (superseded) ++stats_.drops;
  }
  stats_.state = static_cast<int>(CameraState::kDown);
}

void CameraWorker::process(ips::Frame& frame) {
  const std::int64_t started = ips::monotonic_ns();
  stats_.queue_ns += static_cast<std::uint64_t>(std::max<std::int64_t>(0, started - frame.t_delivered_ns));
  const std::shared_ptr<const Runtime> rt = runtime_.get();
  if (reset_detector_.exchange(false) && detector_) detector_->reset();
  const int index = config_.index;
  // First frame, or a reload changed detection or tracking. The camera index as the tracker's
  // phase: the cameras' full-frame searches fall on different frames.
  if (!detector_ || detector_->detection() != rt->config.detection || detector_->tracking() != rt->config.tracking)
    detector_ = std::make_unique<ips::TrackedFrameDetector>(rt->config.detection, rt->config.tracking, index);
  const ips::CameraModel& intrinsics = rt->intrinsics[static_cast<std::size_t>(index)];
  const std::int64_t t0 = ips::monotonic_ns();
  // The web view's camera image needs the whole frame: decoded whole only while a page asks.
  const bool watched = tap_ && tap_->wanted();
  std::vector<ips::MarkerDetection> detections;
  const ips::TrackedFrameDetector::DecodeCounters decoded = detector_->decode_counters();
  const bool ok = detector_->detect(frame, &intrinsics, watched, detections);
  // Whether the camera's frames carry restart markers (they make region decodes cheap).
  const auto& now = detector_->decode_counters();
  if (now.regions > decoded.regions) stats_.restart_markers = now.restart_cuts > decoded.restart_cuts;
  const std::uint64_t damaged = now.restart_damaged - decoded.restart_damaged;
  if (damaged > 0 && stats_.restart_damaged == 0)
    spdlog::warn(
        "{}: a frame's restart markers are not where its header puts them ({}); such frames are decoded "
        "without them and counted (restart_damaged)",
        config_.name, detector_->restart_problem());
  stats_.restart_damaged += damaged;
  if (!ok) {
    if (stats_.corrupt++ == 0)
      spdlog::warn("{}: {}; such frames are skipped and counted", config_.name, detector_->error());
    return;
  }
  if (watched) tap_->offer(frame.gray, detections, frame.sequence, frame.t_mono_ns);
  CameraBatch batch;
  batch.camera_index = index;
  // cameras[].timestamp_offset: the source's stamp -> mid exposure (docs/daemon.md, "Time").
  const auto offset = static_cast<std::int64_t>(std::llround(config_.timestamp_offset_s * 1e9));
  frame.t_mono_ns += offset;
  frame.t_real_ns += offset;
  batch.t_mono_ns = frame.t_mono_ns;
  batch.t_real_ns = frame.t_real_ns;
  batch.t_delivered_ns = frame.t_delivered_ns;
  if (const auto& map = rt->ceiling_maps[static_cast<std::size_t>(index)])
    place_robot(*rt, *map, detections, frame, batch);
  else
    for (const auto& d : detections) observe(*rt, d, frame, batch);
  stats_.detect_ns += static_cast<std::uint64_t>(ips::monotonic_ns() - t0);
  stats_.markers += batch.observations.size() + batch.bodies.size();
  ++stats_.frames;
  queue_.push(std::move(batch));
  // A periodic search for new markers runs after the frame's markers went out: its cost is
  // not in their latency. What it finds is tracked (and published) from the next frame on.
  if (detector_->acquisition_pending()) {
    const std::int64_t t1 = ips::monotonic_ns();
    if (!detector_->acquire(frame, &intrinsics) && stats_.corrupt++ == 0)
      spdlog::warn("{}: {}; such frames are skipped and counted", config_.name, detector_->error());
    stats_.acquire_ns += static_cast<std::uint64_t>(ips::monotonic_ns() - t1);
  }
}

void CameraWorker::observe(const Runtime& rt, const ips::MarkerDetection& d, const ips::Frame& frame,
                           CameraBatch& batch) {
  const int index = config_.index;
  const ips::CameraModel& intrinsics = rt.intrinsics[static_cast<std::size_t>(index)];
  const ips::Mapper& mapper = *rt.mappers[static_cast<std::size_t>(index)];
  const ips::CameraObservation cam = ips::locate_marker(d, intrinsics, rt.sizes.length_of(d.id));
  if (rt.bodies && rt.bodies->body_of(d.id) >= 0) {
    // A body's marker: its full pose -> a view of the body (docs/bodies.md); never also a
    // plain marker. Rejected views (ambiguous, no face fits) are counted.
    ips::BodyObservation view;
    std::string why;
    if (rt.bodies->observe(cam, mapper, index, frame.t_mono_ns, frame.t_real_ns, view, &why)) {
      batch.bodies.push_back(std::move(view));
    } else if (stats_.body_rejected++ == 0) {
      spdlog::info("{}: marker {} of a body gave no body view ({}); such views are skipped and counted", config_.name,
                   d.id, why);
    }
    return;
  }
  ips::WorldObservation w;
  switch (ips::map_marker(cam, mapper, rt.config.markers.height_of(d.id), index, frame.t_mono_ns, frame.t_real_ns, w)) {
    case ips::MappedMarker::kMapped: batch.observations.push_back(w); break;
    case ips::MappedMarker::kNoHeight:
      if (stats_.no_height++ == 0)
        spdlog::warn(
            "{}: marker {} has no known height and the '{}' mapper needs one (markers.ids.{}.height); "
            "such markers are dropped and counted",
            config_.name, d.id, mapper.method(), d.id);
      break;
    case ips::MappedMarker::kDegenerate: break;  // degenerate corners
  }
}

void CameraWorker::place_robot(const Runtime& rt, const ips::CeilingMap& map,
                               const std::vector<ips::MarkerDetection>& detections, const ips::Frame& frame,
                               CameraBatch& batch) {
  if (detections.empty()) return;  // nothing overhead: fusion's filter and hold cover the gap
  const int index = config_.index;
  const ips::OnRobotSettings& settings = rt.config.on_robot.at(index);
  const ips::Localisation l =
      ips::localise(detections, rt.intrinsics[static_cast<std::size_t>(index)], map, settings.mount, settings.localise);
  if (!l.rejected.empty()) {
    if (stats_.ceiling_outliers == 0) {
      std::string ids;
      for (int id : l.rejected) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
      spdlog::warn(
          "{}: ceiling marker(s) {} disagree with the others by more than {} px: moved since the map was made? "
          "Such markers are left out and counted (ceiling_outliers)",
          config_.name, ids, settings.localise.outlier_px);
    }
    stats_.ceiling_outliers += l.rejected.size();
  }
  if (!l.ok) {
    if (stats_.robot_unplaced++ == 0)
      spdlog::info("{}: a frame with markers gave no robot pose ({}); such frames are counted (robot_unplaced)",
                   config_.name, l.why);
    return;
  }
  ++stats_.robot_poses;
  batch.observations.push_back(ips::robot_observation(l, settings, index, frame.t_mono_ns, frame.t_real_ns));
}

}  // namespace ipsd
