#include "ips/capture/v4l2_source.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <set>
#include <span>

#include <spdlog/spdlog.h>
#include <opencv2/imgproc.hpp>

#include "capture/v4l2_util.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace ips {
namespace {

using v4l2::xioctl;

// The realtime-monotonic offset drifts while NTP slews the realtime clock; re-sampling it
// once a second keeps converted timestamps within the slew of one second (< 0.5 ms).
constexpr std::int64_t kOffsetRefreshNs = 1'000'000'000;

std::uint32_t fourcc_of(PixelFormat f) { return f == PixelFormat::kMjpeg ? V4L2_PIX_FMT_MJPEG : V4L2_PIX_FMT_YUYV; }

const char* name_of(PixelFormat f) { return f == PixelFormat::kMjpeg ? "MJPEG" : "YUYV"; }

// errno values that mean "this control is not there", as opposed to "the device is gone".
bool control_missing(int err) { return err == EINVAL || err == ENOTTY || err == ERANGE || err == EACCES; }

}  // namespace

void V4L2Options::validate() const {
  auto bad = [](const std::string& what) { throw InputError("v4l2 source: " + what); };
  if (device.empty()) bad("'device' is empty");
  if (width <= 0 || height <= 0) bad("'width' and 'height' must be positive");
  if (!(fps > 0 && fps <= 1000)) bad("'fps' must be in (0, 1000]");
  if (buffer_count < 4 || buffer_count > 32) bad("'buffers' must be in [4, 32]");
  if (decode_scale != 1 && decode_scale != 2 && decode_scale != 4 && decode_scale != 8)
    bad("'decode_scale' must be 1, 2, 4 or 8");
  const CameraControls& c = controls;
  if (c.exposure_s && !(*c.exposure_s > 0 && *c.exposure_s <= 1)) bad("'exposure' must be in (0, 1] seconds");
  if (c.exposure_s && c.auto_exposure.value_or(false))
    bad("'exposure' (manual exposure time) contradicts 'auto_exposure: true'");
  if (c.gain && *c.gain < 0) bad("'gain' must be >= 0");
  if (c.power_line_hz && *c.power_line_hz != 0 && *c.power_line_hz != 50 && *c.power_line_hz != 60)
    bad("'power_line_hz' must be 0, 50 or 60");
}

V4L2Source::V4L2Source(V4L2Options options) : options_(std::move(options)) { options_.validate(); }

V4L2Source::~V4L2Source() { close(); }

std::string V4L2Source::describe() const { return "v4l2:" + options_.device; }

void V4L2Source::fail(const std::string& what, int err) {
  throw SourceError(describe() + ": " + what + (err != 0 ? std::string(": ") + std::strerror(err) : ""));
}

void V4L2Source::open() {
  close();
  try {
    fd_ = ::open(options_.device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) {
      const int err = errno;
      fail(err == EACCES ? "cannot open (add the user to group 'video')"
                         : "cannot open (unplugged or wrong path? `ips cameras` lists the devices)",
           err);
    }
    v4l2_capability cap{};
    if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) != 0) fail("not a V4L2 device (VIDIOC_QUERYCAP)", errno);
    const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING))
      fail("not a video capture device with streaming I/O (a metadata node? `ips cameras` tells)", 0);
    granted_ = {};
    granted_.driver = reinterpret_cast<const char*>(cap.driver);
    granted_.card = reinterpret_cast<const char*>(cap.card);
    granted_.bus_info = reinterpret_cast<const char*>(cap.bus_info);
    negotiate_format();
    negotiate_rate();
    apply_controls();
    start_streaming();
  } catch (...) {
    close();
    throw;
  }
  ++stats_.opens;
  spdlog::info("{}: streaming {} {}x{} @ {:.3g} fps ({} '{}')", describe(), name_of(granted_.format), granted_.width,
               granted_.height, granted_.fps, granted_.driver, granted_.card);
}

void V4L2Source::negotiate_format() {
  std::set<std::uint32_t> offered;
  v4l2_fmtdesc desc{};
  desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  for (desc.index = 0; xioctl(fd_, VIDIOC_ENUM_FMT, &desc) == 0; ++desc.index) offered.insert(desc.pixelformat);
  const PixelFormat preferred = options_.format;
  const PixelFormat other = preferred == PixelFormat::kMjpeg ? PixelFormat::kYuyv : PixelFormat::kMjpeg;
  PixelFormat chosen = preferred;
  if (!offered.count(fourcc_of(preferred))) {
    if (!offered.count(fourcc_of(other))) {
      std::string list;
      for (std::uint32_t f : offered) list += " " + v4l2::fourcc_string(f);
      fail("offers neither MJPEG nor YUYV (offers:" + (list.empty() ? std::string(" nothing") : list) + ")", 0);
    }
    chosen = other;
    spdlog::warn("{}: {} not offered, falling back to {}", describe(), name_of(preferred), name_of(other));
  }

  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(options_.width);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(options_.height);
  fmt.fmt.pix.pixelformat = fourcc_of(chosen);
  fmt.fmt.pix.field = V4L2_FIELD_ANY;
  if (xioctl(fd_, VIDIOC_S_FMT, &fmt) != 0) fail("VIDIOC_S_FMT", errno);
  if (fmt.fmt.pix.pixelformat != fourcc_of(chosen))
    fail("asked for " + std::string(name_of(chosen)) + ", driver set " + v4l2::fourcc_string(fmt.fmt.pix.pixelformat),
         0);
  granted_.format = chosen;
  granted_.width = static_cast<int>(fmt.fmt.pix.width);
  granted_.height = static_cast<int>(fmt.fmt.pix.height);
  if (granted_.width != options_.width || granted_.height != options_.height)
    spdlog::warn("{}: asked for {}x{}, the device granted {}x{}", describe(), options_.width, options_.height,
                 granted_.width, granted_.height);
  bytes_per_line_ = fmt.fmt.pix.bytesperline;
  if (chosen == PixelFormat::kYuyv) {
    if (bytes_per_line_ == 0) bytes_per_line_ = fmt.fmt.pix.width * 2;
    if (bytes_per_line_ < fmt.fmt.pix.width * 2) fail("YUYV bytesperline smaller than 2 x width", 0);
  }
}

void V4L2Source::negotiate_rate() {
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_G_PARM, &parm) != 0) {
    spdlog::warn("{}: the driver does not report its frame rate (VIDIOC_G_PARM: {})", describe(), std::strerror(errno));
    return;
  }
  if (parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME) {
    // Frame interval as a fraction: 1/30 s, or 1000/29970 s for 29.97 fps.
    const auto den = static_cast<std::uint32_t>(std::lround(options_.fps * 1000));
    const std::uint32_t g = std::gcd(1000u, den);
    parm.parm.capture.timeperframe = {1000 / g, den / g};
    if (xioctl(fd_, VIDIOC_S_PARM, &parm) != 0)
      spdlog::warn("{}: cannot set the frame rate (VIDIOC_S_PARM: {})", describe(), std::strerror(errno));
  } else {
    spdlog::warn("{}: the driver does not let the frame rate be set", describe());
  }
  const v4l2_fract t = parm.parm.capture.timeperframe;
  granted_.fps = t.numerator > 0 ? static_cast<double>(t.denominator) / t.numerator : 0.0;
  if (std::abs(granted_.fps - options_.fps) > 0.01 * options_.fps)
    spdlog::warn("{}: asked for {:.3g} fps, the device granted {:.3g} fps", describe(), options_.fps, granted_.fps);
}

void V4L2Source::apply_controls() {
  // Sets one control and reads back what the device made of it; nullopt if unsupported.
  auto set = [this](std::uint32_t id, std::int32_t value, const char* name) -> std::optional<std::int32_t> {
    v4l2_control ctrl{id, value};
    if (xioctl(fd_, VIDIOC_S_CTRL, &ctrl) != 0) {
      const int err = errno;
      if (!control_missing(err)) fail(std::string("setting control ") + name, err);
      spdlog::warn("{}: control {}={} not supported by the device ({})", describe(), name, value, std::strerror(err));
      return std::nullopt;
    }
    if (xioctl(fd_, VIDIOC_G_CTRL, &ctrl) != 0) ctrl.value = value;
    if (ctrl.value != value)
      spdlog::warn("{}: control {}: asked for {}, the device set {}", describe(), name, value, ctrl.value);
    return ctrl.value;
  };
  const CameraControls& c = options_.controls;
  const std::optional<bool> auto_exposure = c.exposure_s ? std::optional<bool>(false) : c.auto_exposure;
  if (auto_exposure) {
    if (*auto_exposure) {
      // UVC cameras implement "aperture priority" as their auto mode; others plain auto.
      v4l2_control ctrl{V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_APERTURE_PRIORITY};
      if (xioctl(fd_, VIDIOC_S_CTRL, &ctrl) != 0) set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_AUTO, "exposure_auto");
    } else {
      set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL, "exposure_auto");
    }
  }
  if (c.exposure_s) {
    // exposure_absolute is in units of 100 us.
    const auto units = std::max<std::int32_t>(1, static_cast<std::int32_t>(std::lround(*c.exposure_s * 1e4)));
    if (auto v = set(V4L2_CID_EXPOSURE_ABSOLUTE, units, "exposure_absolute")) granted_.exposure_s = *v * 1e-4;
  }
  if (c.gain) granted_.gain = set(V4L2_CID_GAIN, *c.gain, "gain");
  if (c.autofocus)
    if (auto v = set(V4L2_CID_FOCUS_AUTO, *c.autofocus ? 1 : 0, "focus_auto")) granted_.autofocus = *v != 0;
  if (c.power_line_hz) {
    const std::int32_t menu = *c.power_line_hz == 50   ? V4L2_CID_POWER_LINE_FREQUENCY_50HZ
                              : *c.power_line_hz == 60 ? V4L2_CID_POWER_LINE_FREQUENCY_60HZ
                                                       : V4L2_CID_POWER_LINE_FREQUENCY_DISABLED;
    if (auto v = set(V4L2_CID_POWER_LINE_FREQUENCY, menu, "power_line_frequency"))
      granted_.power_line_hz = *v == V4L2_CID_POWER_LINE_FREQUENCY_50HZ   ? 50
                               : *v == V4L2_CID_POWER_LINE_FREQUENCY_60HZ ? 60
                                                                          : 0;
  }
}

void V4L2Source::start_streaming() {
  v4l2_requestbuffers req{};
  req.count = static_cast<std::uint32_t>(options_.buffer_count);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &req) != 0) fail("VIDIOC_REQBUFS (mmap streaming)", errno);
  if (req.count < 2) fail("the driver granted only " + std::to_string(req.count) + " buffer(s)", 0);
  if (static_cast<int>(req.count) != options_.buffer_count)
    spdlog::warn("{}: asked for {} buffers, the driver granted {}", describe(), options_.buffer_count, req.count);
  granted_.buffer_count = static_cast<int>(req.count);
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &buf) != 0) fail("VIDIOC_QUERYBUF", errno);
    void* start = ::mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
    if (start == MAP_FAILED) fail("mmap of buffer " + std::to_string(i), errno);
    buffers_.push_back({start, buf.length});
    if (xioctl(fd_, VIDIOC_QBUF, &buf) != 0) fail("VIDIOC_QBUF", errno);
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) != 0) fail("VIDIOC_STREAMON", errno);
  streaming_ = true;
  last_sequence_.reset();
}

void V4L2Source::close() noexcept {
  if (fd_ >= 0 && streaming_) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(fd_, VIDIOC_STREAMOFF, &type);  // fails with ENODEV when unplugged: nothing to do
  }
  streaming_ = false;
  for (const Mapping& m : buffers_) ::munmap(m.start, m.length);
  if (fd_ >= 0 && !buffers_.empty()) {
    v4l2_requestbuffers req{};  // count 0 frees the driver's buffers now, not at close
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    xioctl(fd_, VIDIOC_REQBUFS, &req);
  }
  buffers_.clear();
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

std::int64_t V4L2Source::realtime_offset_ns(std::int64_t now_mono_ns) {
  if (!offset_sampled_mono_ns_ || now_mono_ns - *offset_sampled_mono_ns_ >= kOffsetRefreshNs) {
    offset_ns_ = realtime_minus_monotonic_ns();
    offset_sampled_mono_ns_ = now_mono_ns;
  }
  return offset_ns_;
}

bool V4L2Source::defer_decode(bool on) {
  defer_decode_ = on && options_.decode_scale == 1;
  return defer_decode_;
}

bool V4L2Source::convert(const Mapping& buffer, std::uint32_t bytesused, Frame& out) {
  cv::Mat& gray = out.gray;
  out.jpeg.clear();
  // Reuse the caller's image when nobody else holds it: no allocation per frame.
  if (gray.u != nullptr && gray.u->refcount > 1) gray.release();
  const int scale = options_.decode_scale;
  if (granted_.format == PixelFormat::kMjpeg) {
    if (bytesused == 0 || bytesused > buffer.length) return false;
    const std::span<const std::uint8_t> jpeg(static_cast<const std::uint8_t*>(buffer.start), bytesused);
    if (defer_decode_) {
      // The buffer goes back to the driver at once: copy (~0.05 ms for 300 kB); the camera
      // thread decodes only what it needs. Only the SOI is checked here.
      if (bytesused < 4 || jpeg[0] != 0xFF || jpeg[1] != 0xD8) return false;
      out.set_jpeg(jpeg);
      return true;
    }
    if (!decoder_.decode_gray(jpeg, gray, scale)) {
      spdlog::debug("{}: corrupt JPEG: {}", describe(), decoder_.error());
      return false;
    }
    return true;
  }
  // YUYV: Y0 U Y1 V ... seen as 2-channel pixels (Y, U|V); channel 0 is the luminance.
  if (static_cast<std::size_t>(bytesused) < static_cast<std::size_t>(bytes_per_line_) * granted_.height) return false;
  const cv::Mat yuyv(granted_.height, granted_.width, CV_8UC2, buffer.start, bytes_per_line_);
  if (scale == 1) {
    cv::extractChannel(yuyv, gray, 0);
  } else {
    cv::Mat y;
    cv::extractChannel(yuyv, y, 0);
    const cv::Size scaled((granted_.width + scale - 1) / scale, (granted_.height + scale - 1) / scale);
    cv::resize(y, gray, scaled, 0, 0, cv::INTER_AREA);
  }
  return true;
}

FrameSource::ReadStatus V4L2Source::read(Frame& out, std::chrono::milliseconds timeout) {
  if (fd_ < 0) throw SourceError(describe() + ": read() on a closed source");
  // Any failure from here on means the device is gone or broken: release it, then report.
  auto fail_closed = [this](const std::string& what, int err) {
    close();
    fail(what, err);
  };
  pollfd p{fd_, POLLIN, 0};
  const int r = ::poll(&p, 1, static_cast<int>(timeout.count()));
  if (r < 0) {
    if (errno == EINTR) return ReadStatus::kTimeout;
    fail_closed("poll", errno);
  }
  if (r == 0) return ReadStatus::kTimeout;
  if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) fail_closed("device error while streaming (unplugged?)", 0);

  v4l2_buffer buf{};
  buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buf.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_DQBUF, &buf) != 0) {
    if (errno == EAGAIN) return ReadStatus::kTimeout;
    fail_closed("VIDIOC_DQBUF", errno);
  }
  if (buf.index >= buffers_.size()) fail_closed("driver returned buffer index " + std::to_string(buf.index), 0);

  if (last_sequence_ && buf.sequence > *last_sequence_ + 1) stats_.driver_drops += buf.sequence - *last_sequence_ - 1;
  last_sequence_ = buf.sequence;

  const std::int64_t now_mono = monotonic_ns();
  std::int64_t t_mono = now_mono;
  if ((buf.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
    t_mono = static_cast<std::int64_t>(buf.timestamp.tv_sec) * 1'000'000'000 +
             static_cast<std::int64_t>(buf.timestamp.tv_usec) * 1000;
  } else if (!warned_timestamp_) {
    warned_timestamp_ = true;
    spdlog::warn("{}: driver timestamps are not monotonic; using the dequeue time instead", describe());
  }

  const bool ok = !(buf.flags & V4L2_BUF_FLAG_ERROR) && convert(buffers_[buf.index], buf.bytesused, out);
  if (xioctl(fd_, VIDIOC_QBUF, &buf) != 0) fail_closed("VIDIOC_QBUF", errno);
  if (!ok) {
    ++stats_.corrupt;
    return ReadStatus::kCorrupt;
  }
  out.sequence = buf.sequence;
  out.t_mono_ns = t_mono;
  out.t_real_ns = t_mono + realtime_offset_ns(now_mono);
  out.t_delivered_ns = now_mono;  // dequeued: decoding from here on is the daemon's cost
  ++stats_.frames;
  return ReadStatus::kFrame;
}

}  // namespace ips
