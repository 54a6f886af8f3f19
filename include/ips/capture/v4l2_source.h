// A V4L2 camera (USB UVC webcams and the like) as an ips::FrameSource, talking to the
// driver directly: MJPEG (preferred) or YUYV, mmap streaming I/O, the driver's monotonic
// buffer timestamps, driver sequence numbers to count drops, camera controls.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ips/capture/frame_source.h"
#include "ips/capture/jpeg_decoder.h"

namespace ips {

/// Camera controls applied at every open() with VIDIOC_S_CTRL. Unset = leave the device's
/// current setting alone. A control the device lacks is a logged warning, not an error;
/// a value the device adjusts (clamps) is logged and visible in V4L2Source::granted().
struct CameraControls {
  /// true = automatic exposure (aperture priority), false = manual. Unset with exposure_s
  /// set means manual.
  std::optional<bool> auto_exposure;
  /// Manual exposure time in seconds (V4L2 exposure_absolute is in 100 us units, so the
  /// resolution is 1e-4 s). For markers on moving robots keep it short: blur = speed x time.
  std::optional<double> exposure_s;
  /// Analogue gain in the device's own units (UVC: typically 0..255).
  std::optional<int> gain;
  /// false = autofocus off (a ceiling camera looks at a fixed distance).
  std::optional<bool> autofocus;
  /// Mains frequency of the lighting in Hz: 50, 60, or 0 = anti-flicker off.
  std::optional<int> power_line_hz;

  bool operator==(const CameraControls&) const = default;
};

enum class PixelFormat { kMjpeg, kYuyv };

struct V4L2Options {
  /// Device node. Prefer the stable /dev/v4l/by-id/... symlink (see `ips cameras`):
  /// /dev/videoN numbers change with plug order.
  std::string device;
  /// Requested frame size in pixels; the driver grants the nearest it supports.
  int width = 1920;
  int height = 1080;
  /// Preferred pixel format; the other one is the fallback. MJPEG carries 1080p30 over
  /// USB 2; YUYV usually only manages small sizes or low rates there.
  PixelFormat format = PixelFormat::kMjpeg;
  /// Requested frame rate in frames per second (VIDIOC_S_PARM); the driver may grant another.
  double fps = 30.0;
  /// Number of mmap buffers (>= 4). More buffers absorb longer processing hiccups at the
  /// cost of latency when the consumer falls behind (frames are delivered oldest first).
  int buffer_count = 4;
  /// Output scale divisor 1, 2, 4 or 8: MJPEG is decoded at reduced size in the DCT domain
  /// (much cheaper); YUYV's luminance plane is area-averaged down. 1 = full resolution.
  int decode_scale = 1;
  CameraControls controls;

  /// Throws ips::InputError naming the offending field.
  void validate() const;

  bool operator==(const V4L2Options&) const = default;
};

/// What the device actually granted at the last open().
struct V4L2Granted {
  PixelFormat format = PixelFormat::kMjpeg;
  int width = 0;
  int height = 0;
  double fps = 0;  ///< 0 if the driver does not report a frame interval
  int buffer_count = 0;
  std::string driver, card, bus_info;
  /// Control values read back after setting them (only the controls that were set and
  /// supported): exposure_s in seconds, gain, autofocus (0/1), power_line_hz.
  std::optional<double> exposure_s;
  std::optional<int> gain;
  std::optional<bool> autofocus;
  std::optional<int> power_line_hz;
};

/// Counters since construction (they survive close/open cycles).
struct V4L2Stats {
  std::uint64_t frames = 0;        ///< frames delivered (kFrame)
  std::uint64_t corrupt = 0;       ///< frames dropped as undecodable (kCorrupt)
  std::uint64_t driver_drops = 0;  ///< frames lost in the driver: gaps in the sequence numbers
  std::uint64_t opens = 0;         ///< successful open() calls
};

class V4L2Source : public FrameSource {
 public:
  explicit V4L2Source(V4L2Options options);
  ~V4L2Source() override;
  V4L2Source(const V4L2Source&) = delete;
  V4L2Source& operator=(const V4L2Source&) = delete;

  /// Opens and configures the device and starts streaming. Throws ips::SourceError (device
  /// missing, not a capture device, no MJPEG/YUYV, ...) after releasing everything.
  void open() override;
  /// Waits up to `timeout` for a frame. kCorrupt for an undecodable frame (the buffer is
  /// requeued). Throws ips::SourceError when the device fails (unplugged: ENODEV/EIO);
  /// the source is then already closed.
  ReadStatus read(Frame& out, std::chrono::milliseconds timeout) override;
  /// Stops streaming, unmaps every buffer and closes the fd. Safe to call repeatedly.
  void close() noexcept override;
  std::string describe() const override;
  /// MJPEG frames at decode_scale 1 are then copied out of the driver's buffer undecoded
  /// (Frame::jpeg); YUYV and reduced-scale decoding are unaffected. True for decode_scale 1.
  bool defer_decode(bool on) override;

  bool is_open() const { return fd_ >= 0; }
  const V4L2Granted& granted() const { return granted_; }
  const V4L2Stats& stats() const { return stats_; }
  const V4L2Options& options() const { return options_; }

 private:
  struct Mapping {
    void* start = nullptr;
    std::size_t length = 0;
  };

  [[noreturn]] void fail(const std::string& what, int err);
  void negotiate_format();
  void negotiate_rate();
  void apply_controls();
  void start_streaming();
  bool convert(const Mapping& buffer, std::uint32_t bytesused, Frame& out);
  std::int64_t realtime_offset_ns(std::int64_t t_mono_ns);

  V4L2Options options_;
  int fd_ = -1;
  std::vector<Mapping> buffers_;
  bool streaming_ = false;
  std::uint32_t bytes_per_line_ = 0;
  V4L2Granted granted_;
  V4L2Stats stats_;
  JpegDecoder decoder_;
  std::optional<std::uint32_t> last_sequence_;
  bool warned_timestamp_ = false;
  bool defer_decode_ = false;
  std::int64_t offset_ns_ = 0;                          // realtime - monotonic
  std::optional<std::int64_t> offset_sampled_mono_ns_;  // when offset_ns_ was sampled
};

}  // namespace ips
