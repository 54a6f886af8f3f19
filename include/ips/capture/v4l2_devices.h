// Discovering V4L2 devices and what they offer, for `ips cameras` (writing the config).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ips {

struct V4L2FrameSize {
  int width = 0;
  int height = 0;
  std::vector<double> fps;  ///< discrete frame rates, highest first; empty if not enumerable
  std::string fps_range;    ///< for stepwise/continuous intervals, e.g. "5-30 fps"
};

struct V4L2FormatInfo {
  std::string fourcc;       ///< "MJPG", "YUYV", ...
  std::string description;  ///< the driver's, e.g. "Motion-JPEG"
  std::vector<V4L2FrameSize> sizes;
  std::string size_range;  ///< for stepwise/continuous sizes, e.g. "16x16-1920x1080 step 8x8"
};

/// A camera control that V4L2Source can set, in the driver's own units.
struct V4L2ControlInfo {
  std::string key;  ///< the config key under `controls`: auto_exposure, exposure, gain, autofocus,
                    ///< power_line_hz
  std::int32_t min = 0, max = 0, default_value = 0, current = 0;
};

struct V4L2DeviceInfo {
  std::string path;   ///< e.g. /dev/video0
  std::string error;  ///< non-empty if the device could not be opened or queried
  std::string driver, card, bus_info;
  bool capture = false;  ///< a video capture node with streaming I/O (UVC metadata nodes are not)
  std::vector<V4L2FormatInfo> formats;
  std::vector<V4L2ControlInfo> controls;  ///< only those the device supports
  std::vector<std::string> links;         ///< /dev/v4l/by-id and by-path symlinks resolving to `path`
};

/// Opens `path` read-only-ish (O_RDWR | O_NONBLOCK, no streaming) and asks what it offers.
/// Failures are reported in `error`, never thrown.
V4L2DeviceInfo query_v4l2_device(const std::string& path);

/// Every `video<N>` node in `dev_dir` (default /dev) in numeric order, queried, with the
/// symlinks in `dev_dir`/v4l/by-id and by-path that point at each.
std::vector<V4L2DeviceInfo> list_v4l2_devices(const std::string& dev_dir = "/dev");

}  // namespace ips
