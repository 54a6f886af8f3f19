// Frame sets: the fusion the daemon had before asynchronous fusion, kept for the tests only.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <vector>

#include "ips/fusion/fusion.h"

namespace ips {

/// The daemon's fusion before asynchronous fusion (ips/fusion/track_fusion.h): the baseline
/// track_fusion_test compares against (not in the library: nothing else uses it). Collects per-frame batches from the
/// cameras into frame sets: batches whose capture times lie within `window_ns` of the set's first batch. A set is
/// complete (returned by add or poll) when every expected camera has delivered, when a batch arrives that does not fit
/// (too late or a camera delivering twice), or when `max_wait_ns` of wall time passed since
/// the set opened. Not thread-safe: owned by the fusion thread.
class FrameGrouper {
 public:
  FrameGrouper(std::int64_t window_ns, std::int64_t max_wait_ns);

  /// Cameras expected in every set (the ones currently delivering); a set completes as soon
  /// as all of them are in. Empty = complete only by window/time-out.
  void set_expected_cameras(std::set<int> cameras) { expected_ = std::move(cameras); }

  /// Adds a batch at wall time `now_ns`; appends completed sets to `done`.
  void add(FrameObservations batch, std::int64_t now_ns, std::vector<std::vector<FrameObservations>>& done);
  /// Closes the open set if it waited longer than max_wait_ns.
  void poll(std::int64_t now_ns, std::vector<std::vector<FrameObservations>>& done);
  /// Wall time at which the open set times out, or -1 if none is open.
  std::int64_t deadline_ns() const { return open_.empty() ? -1 : opened_at_ + max_wait_ns_; }

 private:
  void close(std::vector<std::vector<FrameObservations>>& done);

  std::int64_t window_ns_;
  std::int64_t max_wait_ns_;
  std::set<int> expected_;
  std::vector<FrameObservations> open_;
  std::set<int> open_cameras_;
  std::int64_t first_capture_ns_ = 0;
  std::int64_t opened_at_ = 0;
};

inline FrameGrouper::FrameGrouper(std::int64_t window_ns, std::int64_t max_wait_ns)
    : window_ns_(window_ns), max_wait_ns_(max_wait_ns) {}

inline void FrameGrouper::close(std::vector<std::vector<FrameObservations>>& done) {
  if (open_.empty()) return;
  done.push_back(std::move(open_));
  open_.clear();
  open_cameras_.clear();
}

inline void FrameGrouper::add(FrameObservations batch, std::int64_t now_ns,
                              std::vector<std::vector<FrameObservations>>& done) {
  poll(now_ns, done);
  const bool fits = !open_.empty() && !open_cameras_.count(batch.camera_index) &&
                    std::llabs(batch.t_mono_ns - first_capture_ns_) <= window_ns_;
  if (!fits) {
    close(done);
    first_capture_ns_ = batch.t_mono_ns;
    opened_at_ = now_ns;
  }
  open_cameras_.insert(batch.camera_index);
  open_.push_back(std::move(batch));
  if (!expected_.empty() &&
      std::includes(open_cameras_.begin(), open_cameras_.end(), expected_.begin(), expected_.end()))
    close(done);
}

inline void FrameGrouper::poll(std::int64_t now_ns, std::vector<std::vector<FrameObservations>>& done) {
  if (!open_.empty() && now_ns - opened_at_ >= max_wait_ns_) close(done);
}

}  // namespace ips
