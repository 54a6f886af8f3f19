#include "ips/capture/frame_scheduler.h"

#include <utility>

#include "ips/core/clock.h"

namespace ips {

FrameScheduler::FrameScheduler(std::vector<std::int64_t> budget_ns, Clock clock)
    : budget_ns_(std::move(budget_ns)),
      clock_(clock ? std::move(clock) : Clock(monotonic_ns)),
      slots_(budget_ns_.size()) {}

void FrameScheduler::recycle(Slot& slot, Frame&& frame) {
  const bool has_buffers = frame.jpeg.capacity() > 0 || !frame.gray.empty();
  if (has_buffers && slot.spent.size() < kSpare) slot.spent.push_back(std::move(frame));
}

Frame FrameScheduler::submit(int camera, Frame&& frame, bool* superseded) {
  std::lock_guard lock(mutex_);
  Slot& slot = slots_.at(static_cast<std::size_t>(camera));
  if (superseded) *superseded = slot.waiting.has_value();
  if (slot.waiting) {
    ++slot.counters.superseded;
    recycle(slot, std::move(*slot.waiting));
  }
  slot.waiting = std::move(frame);
  Frame next;
  if (!slot.spent.empty()) {
    next = std::move(slot.spent.back());
    slot.spent.pop_back();
  }
  ready_.notify_one();
  return next;
}

bool FrameScheduler::take(int& camera, Frame& frame, std::chrono::nanoseconds timeout) {
  std::unique_lock lock(mutex_);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!closed_) {
    const std::int64_t now = clock_();
    int oldest = -1;
    for (std::size_t c = 0; c < slots_.size(); ++c) {
      Slot& slot = slots_[c];
      if (!slot.waiting || slot.busy) continue;
      if (now - slot.waiting->t_delivered_ns > budget_ns_[c]) {  // waited a whole budget: too late to start
        ++slot.counters.over_budget;
        recycle(slot, std::move(*slot.waiting));
        slot.waiting.reset();
        continue;
      }
      if (oldest < 0 || slot.waiting->t_mono_ns < slots_[static_cast<std::size_t>(oldest)].waiting->t_mono_ns)
        oldest = static_cast<int>(c);
    }
    if (oldest >= 0) {
      Slot& slot = slots_[static_cast<std::size_t>(oldest)];
      camera = oldest;
      frame = std::move(*slot.waiting);
      slot.waiting.reset();
      slot.busy = true;
      ++slot.counters.taken;
      slot.counters.wait_ns += now - frame.t_delivered_ns;
      return true;
    }
    if (ready_.wait_until(lock, deadline) == std::cv_status::timeout) return false;
  }
  return false;
}

void FrameScheduler::done(int camera, Frame&& spent) {
  std::lock_guard lock(mutex_);
  Slot& slot = slots_.at(static_cast<std::size_t>(camera));
  slot.busy = false;
  recycle(slot, std::move(spent));
  if (slot.waiting) ready_.notify_one();
}

void FrameScheduler::close() {
  std::lock_guard lock(mutex_);
  closed_ = true;
  ready_.notify_all();
}

FrameScheduler::Counters FrameScheduler::counters(int camera) const {
  std::lock_guard lock(mutex_);
  return slots_.at(static_cast<std::size_t>(camera)).counters;
}

}  // namespace ips
