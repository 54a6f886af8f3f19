#include <chrono>

#include "ips/web/web.h"

namespace ips {

void FrameTap::offer(const cv::Mat& gray, const std::vector<MarkerDetection>& detections, std::uint64_t sequence,
                     std::int64_t t_mono_ns) {
  auto s = std::make_shared<FrameSnapshot>();
  s->sequence = sequence;
  s->t_mono_ns = t_mono_ns;
  s->gray = gray.clone();  // the only cost on the camera thread: one memcpy of the frame
  s->detections = detections;
  {
    std::lock_guard lock(mutex_);
    latest_ = std::move(s);
    ++generation_;
    wanted_.store(false, std::memory_order_relaxed);
  }
  ++handed_over_;
  cv_.notify_all();
}

std::shared_ptr<const FrameSnapshot> FrameTap::request(std::int64_t timeout_ns) {
  std::unique_lock lock(mutex_);
  const std::uint64_t before = generation_;
  wanted_.store(true, std::memory_order_relaxed);
  if (!cv_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [&] { return generation_ != before; })) return nullptr;
  return latest_;
}

}  // namespace ips
