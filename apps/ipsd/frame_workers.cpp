#include "frame_workers.h"

#include <pthread.h>

#include <chrono>
#include <string>

#include "ips/core/clock.h"

namespace ipsd {

namespace {
// How long a worker waits for a frame: bounds the time to notice a stop and the heartbeat period.
constexpr std::chrono::milliseconds kTakeTimeout{100};
}  // namespace

FrameWorkers::FrameWorkers(ips::FrameScheduler& scheduler, std::vector<CameraWorker*> cameras, int count)
    : scheduler_(scheduler), cameras_(std::move(cameras)) {
  for (int k = 0; k < std::max(1, count); ++k)
    heartbeats_.push_back(std::make_unique<std::atomic<std::int64_t>>(ips::monotonic_ns()));
}

FrameWorkers::~FrameWorkers() {
  request_stop();
  join();
}

void FrameWorkers::start() {
  for (int k = 0; k < count(); ++k) threads_.emplace_back([this, k] { run(k); });
}

void FrameWorkers::join() {
  for (auto& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

void FrameWorkers::run(int k) {
  const std::string name = "work:" + std::to_string(k);  // visible in top -H
  pthread_setname_np(pthread_self(), name.c_str());
  ips::Frame frame;
  int camera = -1;
  while (!stop_) {
    heartbeats_[static_cast<std::size_t>(k)]->store(ips::monotonic_ns());
    if (!scheduler_.take(camera, frame, kTakeTimeout)) continue;
    cameras_[static_cast<std::size_t>(camera)]->process(frame);
    scheduler_.done(camera, std::move(frame));
  }
}

}  // namespace ipsd
