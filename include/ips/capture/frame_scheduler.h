// Which camera frame is processed next. Capture threads only dequeue frames and hand them over
// here; a pool of workers takes them oldest capture first, one frame per camera at a time (a
// camera's tracker state is sequential). A camera keeps at most one frame waiting: a newer one
// replaces it (the older would be worked on after the newer is already there). A frame that has
// waited longer than its camera's budget is dropped before any work is spent on it. Both are
// counted. Spent frames go back to their camera's capture thread, so that JPEG and image
// buffers are reused frame to frame instead of allocated.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <vector>

#include "ips/capture/frame_source.h"

namespace ips {

class FrameScheduler {
 public:
  struct Counters {
    std::uint64_t taken = 0;        ///< frames handed to a worker
    std::uint64_t superseded = 0;   ///< frames replaced by a newer one of the same camera before a worker was free
    std::uint64_t over_budget = 0;  ///< frames dropped because they waited longer than the budget
    std::int64_t wait_ns = 0;       ///< sum over taken frames of delivery -> taken
  };
  using Clock = std::function<std::int64_t()>;

  /// `budget_ns[c]`: camera c's frame is dropped when no worker took it within this long of its
  /// delivery (Frame::t_delivered_ns). `clock`: CLOCK_MONOTONIC nanoseconds (tests inject theirs).
  explicit FrameScheduler(std::vector<std::int64_t> budget_ns, Clock clock = {});

  /// Capture thread of `camera`: hands its newest frame over and gets a spent frame of this camera
  /// back to read the next one into (its buffers keep their capacity), or an empty one.
  /// `superseded` (optional): set to whether a waiting frame of the camera was replaced.
  Frame submit(int camera, Frame&& frame, bool* superseded = nullptr);

  /// Worker: waits up to `timeout` for the oldest waiting frame (by capture time) whose camera no
  /// other worker is processing. False on timeout or after close().
  bool take(int& camera, Frame& frame, std::chrono::nanoseconds timeout);

  /// Worker: done with `camera`'s frame; `spent` goes back to the camera's capture thread.
  void done(int camera, Frame&& spent);

  /// Wakes every waiting worker; take() returns false from then on.
  void close();

  Counters counters(int camera) const;
  int cameras() const { return static_cast<int>(slots_.size()); }

 private:
  struct Slot {
    std::optional<Frame> waiting;
    bool busy = false;
    std::vector<Frame> spent;  ///< at most kSpare, for submit() to hand back
    Counters counters;
  };
  static constexpr std::size_t kSpare = 2;
  void recycle(Slot& slot, Frame&& frame);

  std::vector<std::int64_t> budget_ns_;
  Clock clock_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::vector<Slot> slots_;
  bool closed_ = false;
};

}  // namespace ips
