#include "ips/sim/synthetic_source.h"

#include <cmath>
#include <thread>

#include "ips/clock.h"
#include "ips/error.h"

namespace ips::sim {

SyntheticSource::SyntheticSource(std::shared_ptr<const Scene> scene, SyntheticSourceOptions options)
    : scene_(std::move(scene)),
      options_(std::move(options)),
      renderer_(*scene_, scene_->camera_index(options_.camera)) {
  if (!(options_.fps > 0 && options_.fps <= 1000)) {
    throw InputError("synthetic source: fps must be in (0, 1000], got " +
                     std::to_string(options_.fps));
  }
}

void SyntheticSource::open() {
  epoch_mono_ns_ = options_.epoch_mono_ns != 0 ? options_.epoch_mono_ns : monotonic_ns();
  real_minus_mono_ns_ = realtime_minus_monotonic_ns();
  next_ = 0;
  delivered_ = 0;
  open_ = true;
}

void SyntheticSource::close() noexcept { open_ = false; }

std::string SyntheticSource::describe() const {
  return "synthetic:" + options_.camera + "@" + std::to_string(options_.fps) + "fps";
}

std::int64_t SyntheticSource::frame_time_ns(std::uint64_t k) const {
  return epoch_mono_ns_ + std::llround(static_cast<double>(k) * 1e9 / options_.fps);
}

FrameSource::ReadStatus SyntheticSource::read(Frame& out, std::chrono::milliseconds timeout) {
  if (!open_) throw SourceError(describe() + ": read() before open()");
  if (options_.max_frames != 0 && delivered_ >= options_.max_frames) return ReadStatus::kEnd;
  if (options_.realtime) {
    const std::int64_t now = monotonic_ns();
    // Behind schedule: skip to the newest frame already due (a camera would have dropped the rest).
    if (now > frame_time_ns(next_)) {
      const double due =
          std::floor(static_cast<double>(now - epoch_mono_ns_) * options_.fps * 1e-9);
      next_ = std::max<std::uint64_t>(next_, static_cast<std::uint64_t>(due));
    }
    const std::int64_t wait = frame_time_ns(next_) - now;
    if (wait > 0) {
      const std::int64_t limit =
          std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
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
    jpeg_ = encode_jpeg(rendered_, quality, options_.colour_jpeg);
    if (!decoder_.decode_gray(jpeg_, out.gray)) {
      return ReadStatus::kCorrupt;  // cannot happen for our own encoder; kept honest
    }
  } else {
    jpeg_.clear();
  }
  ++delivered_;
  return ReadStatus::kFrame;
}

}  // namespace ips::sim
