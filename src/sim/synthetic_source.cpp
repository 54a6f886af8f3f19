#include "ips/sim/synthetic_source.h"

#include <pthread.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <thread>

#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace ips::sim {

SyntheticSource::SyntheticSource(std::shared_ptr<const Scene> scene, SyntheticSourceOptions options)
    : scene_(std::move(scene)),
      options_(std::move(options)),
      renderer_(*scene_, scene_->camera_index(options_.camera)) {
  if (!(options_.fps > 0 && options_.fps <= 1000)) {
    throw InputError("synthetic source: fps must be in (0, 1000], got " + std::to_string(options_.fps));
  }
}

SyntheticSource::~SyntheticSource() { close(); }

void SyntheticSource::open() {
  close();
  epoch_mono_ns_ = options_.epoch_mono_ns != 0 ? options_.epoch_mono_ns : monotonic_ns();
  real_minus_mono_ns_ = realtime_minus_monotonic_ns();
  next_ = 0;
  delivered_ = 0;
  open_ = true;
  if (options_.render_ahead && options_.realtime) {
    external_state_ = false;
    for (const auto& m : scene_->markers)
      if (m.trajectory.kind == Trajectory::Kind::kPlacements) external_state_ = true;
    delay_ns_ = options_.transport_delay_ns >= 0 ? options_.transport_delay_ns : std::llround(1e9 / options_.fps);
    stop_render_ = false;
    ready_.clear();
    render_thread_ = std::thread([this] { render_loop(); });
  }
}

void SyntheticSource::close() noexcept {
  open_ = false;
  if (render_thread_.joinable()) {
    {
      std::lock_guard lock(mutex_);
      stop_render_ = true;
    }
    cv_.notify_all();
    render_thread_.join();
  }
}

void SyntheticSource::render_loop() {
  const std::string name = ("sim:" + options_.camera).substr(0, 15);
  pthread_setname_np(pthread_self(), name.c_str());
  // Niced: the simulator runs on what the daemon leaves over, and its cost shows apart.
  (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 10);
  const int quality = scene_->render.jpeg_quality;
  std::uint64_t k = 0;
  cv::Mat image;
  while (true) {
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [this] { return stop_render_ || ready_.size() < kAhead; });
      if (stop_render_) return;
      // A hand-placed marker (a placements control file) is outside state, read when the frame
      // is rendered: such a frame must not be rendered before it is captured, or it would show
      // where the marker was before the hand moved it.
      if (external_state_) {
        const std::int64_t capture = frame_time_ns(k);
        for (std::int64_t now = monotonic_ns(); !stop_render_ && now < capture; now = monotonic_ns())
          cv_.wait_for(lock, std::chrono::nanoseconds(capture - now));
        if (stop_render_) return;
      }
    }
    // Behind schedule: skip to the newest frame already due for delivery (a camera drops the rest).
    const std::int64_t now = monotonic_ns();
    if (now > frame_time_ns(k) + delay_ns_) {
      const double due =
          std::floor(static_cast<double>(now - delay_ns_ - epoch_mono_ns_ - options_.phase_ns) * options_.fps * 1e-9);
      if (due > static_cast<double>(k)) k = static_cast<std::uint64_t>(due);
    }
    Rendered r;
    r.k = k;
    renderer_.render(scene_time(frame_time_ns(k)), image, k);
    if (quality > 0) {
      r.jpeg = encode_jpeg(image, quality, options_.colour_jpeg, scene_->render.jpeg_restart_rows);
    } else {
      r.gray = image.clone();
    }
    r.ready_ns = monotonic_ns();
    {
      std::lock_guard lock(mutex_);
      ready_.push_back(std::move(r));
    }
    cv_.notify_all();
    ++k;
  }
}

FrameSource::ReadStatus SyntheticSource::read_ahead(Frame& out, std::chrono::milliseconds timeout) {
  const std::int64_t deadline = monotonic_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
  Rendered r;
  {
    std::unique_lock lock(mutex_);
    while (true) {
      const std::int64_t now = monotonic_ns();
      std::int64_t wake = deadline;
      if (!ready_.empty()) {
        const std::int64_t due = frame_time_ns(ready_.front().k) + delay_ns_;
        if (due <= now) break;
        wake = std::min(wake, due);
      }
      if (now >= deadline) return ReadStatus::kTimeout;
      cv_.wait_for(lock, std::chrono::nanoseconds(wake - now));
    }
    r = std::move(ready_.front());
    ready_.pop_front();
  }
  cv_.notify_all();
  const std::int64_t due = frame_time_ns(r.k) + delay_ns_;
  out.sequence = r.k;
  out.t_mono_ns = frame_time_ns(r.k);
  out.t_real_ns = out.t_mono_ns + real_minus_mono_ns_;
  out.t_delivered_ns = std::max(due, r.ready_ns);
  next_ = r.k + 1;
  ++delivered_;
  if (!r.jpeg.empty()) {
    jpeg_ = std::move(r.jpeg);
    if (defer_decode_) {
      out.set_jpeg(jpeg_);
      return ReadStatus::kFrame;
    }
    if (!decoder_.decode_gray(jpeg_, out.gray)) return ReadStatus::kCorrupt;
  } else {
    jpeg_.clear();
    out.gray = r.gray;
  }
  return ReadStatus::kFrame;
}

bool SyntheticSource::defer_decode(bool on) {
  defer_decode_ = on && scene_->render.jpeg_quality > 0;
  return defer_decode_;
}

std::string SyntheticSource::describe() const {
  return "synthetic:" + options_.camera + "@" + std::to_string(options_.fps) + "fps";
}

std::int64_t SyntheticSource::frame_time_ns(std::uint64_t k) const {
  return epoch_mono_ns_ + options_.phase_ns + std::llround(static_cast<double>(k) * 1e9 / options_.fps);
}

FrameSource::ReadStatus SyntheticSource::read(Frame& out, std::chrono::milliseconds timeout) {
  if (!open_) throw SourceError(describe() + ": read() before open()");
  if (options_.max_frames != 0 && delivered_ >= options_.max_frames) return ReadStatus::kEnd;
  if (render_thread_.joinable()) return read_ahead(out, timeout);
  if (options_.realtime) {
    const std::int64_t now = monotonic_ns();
    // Behind schedule: skip to the newest frame already due (a camera would have dropped the rest).
    if (now > frame_time_ns(next_)) {
      const double due =
          std::floor(static_cast<double>(now - epoch_mono_ns_ - options_.phase_ns) * options_.fps * 1e-9);
      next_ = std::max<std::uint64_t>(next_, static_cast<std::uint64_t>(due));
    }
    const std::int64_t wait = frame_time_ns(next_) - now;
    if (wait > 0) {
      const std::int64_t limit = std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
      if (wait > limit) {
        std::this_thread::sleep_for(std::chrono::nanoseconds(limit));
        return ReadStatus::kTimeout;
      }
      std::this_thread::sleep_for(std::chrono::nanoseconds(wait));
    }
  }
  const std::uint64_t k = next_++;
  out.sequence = k;
  out.t_mono_ns = frame_time_ns(k);
  out.t_real_ns = out.t_mono_ns + real_minus_mono_ns_;
  const int quality = scene_->render.jpeg_quality;
  renderer_.render(scene_time(out.t_mono_ns), quality > 0 ? rendered_ : out.gray, k);
  if (quality > 0) {
    jpeg_ = encode_jpeg(rendered_, quality, options_.colour_jpeg, scene_->render.jpeg_restart_rows);
    if (defer_decode_) {
      out.set_jpeg(jpeg_);
    } else if (!decoder_.decode_gray(jpeg_, out.gray)) {
      return ReadStatus::kCorrupt;  // cannot happen for our own encoder; kept honest
    }
  } else {
    jpeg_.clear();
  }
  ++delivered_;
  out.t_delivered_ns = std::max(out.t_mono_ns, monotonic_ns());
  return ReadStatus::kFrame;
}

}  // namespace ips::sim
