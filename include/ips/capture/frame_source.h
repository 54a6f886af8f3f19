// Where frames come from: a V4L2 camera, a video file / image folder, or the simulator.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace ips {

/// One greyscale frame with its capture time.
struct Frame {
  std::uint64_t sequence = 0;  ///< source's frame counter (V4L2: driver sequence; gaps = driver drops)
  std::int64_t t_mono_ns = 0;  ///< capture time, CLOCK_MONOTONIC nanoseconds
  std::int64_t t_real_ns = 0;  ///< the same instant on CLOCK_REALTIME
  /// When the source had the frame ready for the daemon, CLOCK_MONOTONIC (V4L2: dequeue; a
  /// synthetic camera: capture time + transport delay); 0 = the reader stamps it on return.
  std::int64_t t_delivered_ns = 0;
  cv::Mat gray;  ///< CV_8UC1; detection needs nothing else
  /// Deferred decoding (FrameSource::defer_decode): when non-empty, this frame's image is
  /// this JPEG and `gray` is NOT it (only a buffer the reader may decode into, e.g. just the
  /// regions its tracker needs: ips::TrackedFrameDetector). Empty: `gray` is the image.
  std::vector<std::uint8_t> jpeg;

  /// Copies a camera's JPEG frame into `jpeg` with a quarter more room than it needs when the
  /// buffer must grow: the next frames, a little larger or smaller, reuse it (no allocation
  /// per frame on the steady-state path).
  void set_jpeg(std::span<const std::uint8_t> bytes) {
    if (jpeg.capacity() < bytes.size()) {
      jpeg.clear();
      jpeg.reserve(bytes.size() + bytes.size() / 4);
    }
    jpeg.assign(bytes.begin(), bytes.end());
  }
};

/// A source of frames. One instance is used by one thread.
/// open() and read() throw ips::SourceError when the device fails (unplugged, ended);
/// the caller closes it and reopens with back-off.
class FrameSource {
 public:
  enum class ReadStatus {
    kFrame,    ///< `out` holds a new frame
    kTimeout,  ///< nothing arrived within the timeout
    kCorrupt,  ///< a frame arrived but could not be decoded (counted and skipped by the caller)
    kEnd,      ///< the source has ended for good (a finite file that does not loop)
  };

  virtual ~FrameSource() = default;
  virtual void open() = 0;
  virtual ReadStatus read(Frame& out, std::chrono::milliseconds timeout) = 0;
  virtual void close() noexcept = 0;
  /// Human-readable name for logs, e.g. "v4l2:/dev/v4l/by-id/usb-ELP...".
  virtual std::string describe() const = 0;
  /// Asks the source to hand JPEG frames over undecoded in Frame::jpeg (the reader decodes
  /// what it needs; a corrupt JPEG then shows when the reader decodes it, not as kCorrupt).
  /// Returns whether it will: sources without JPEG frames (or that must decode at reduced
  /// scale) keep filling `gray`. Call before open() or between reads.
  virtual bool defer_decode(bool on) {
    (void)on;
    return false;
  }
};

}  // namespace ips
