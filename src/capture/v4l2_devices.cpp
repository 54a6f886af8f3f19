#include "ips/capture/v4l2_devices.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

#include "capture/v4l2_util.h"

namespace ips {
namespace {

namespace fs = std::filesystem;
using v4l2::xioctl;

double fps_of(const v4l2_fract& interval) {
  return interval.numerator > 0 ? static_cast<double>(interval.denominator) / interval.numerator : 0.0;
}

void query_intervals(int fd, std::uint32_t fourcc, V4L2FrameSize& size) {
  v4l2_frmivalenum ival{};
  ival.pixel_format = fourcc;
  ival.width = static_cast<std::uint32_t>(size.width);
  ival.height = static_cast<std::uint32_t>(size.height);
  for (ival.index = 0; xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &ival) == 0; ++ival.index) {
    if (ival.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
      size.fps.push_back(fps_of(ival.discrete));
    } else {  // stepwise/continuous: the fastest rate has the shortest interval
      size.fps_range = fmt::format("{:.4g}-{:.4g} fps", fps_of(ival.stepwise.max), fps_of(ival.stepwise.min));
      break;
    }
  }
  std::sort(size.fps.rbegin(), size.fps.rend());
}

void query_sizes(int fd, V4L2FormatInfo& format, std::uint32_t fourcc) {
  v4l2_frmsizeenum fs{};
  fs.pixel_format = fourcc;
  for (fs.index = 0; xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) == 0; ++fs.index) {
    if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
      V4L2FrameSize size;
      size.width = static_cast<int>(fs.discrete.width);
      size.height = static_cast<int>(fs.discrete.height);
      query_intervals(fd, fourcc, size);
      format.sizes.push_back(std::move(size));
    } else {
      const auto& s = fs.stepwise;
      format.size_range = fmt::format("{}x{}-{}x{} step {}x{}", s.min_width, s.min_height, s.max_width, s.max_height,
                                      s.step_width, s.step_height);
      break;
    }
  }
}

void query_controls(int fd, std::vector<V4L2ControlInfo>& controls) {
  static const std::pair<std::uint32_t, const char*> kControls[] = {{V4L2_CID_EXPOSURE_AUTO, "auto_exposure"},
                                                                    {V4L2_CID_EXPOSURE_ABSOLUTE, "exposure"},
                                                                    {V4L2_CID_GAIN, "gain"},
                                                                    {V4L2_CID_FOCUS_AUTO, "autofocus"},
                                                                    {V4L2_CID_POWER_LINE_FREQUENCY, "power_line_hz"}};
  for (const auto& [id, key] : kControls) {
    v4l2_queryctrl q{};
    q.id = id;
    if (xioctl(fd, VIDIOC_QUERYCTRL, &q) != 0 || (q.flags & V4L2_CTRL_FLAG_DISABLED)) continue;
    v4l2_control value{id, q.default_value};
    if (xioctl(fd, VIDIOC_G_CTRL, &value) != 0) value.value = q.default_value;
    controls.push_back({key, q.minimum, q.maximum, q.default_value, value.value});
  }
}

}  // namespace

V4L2DeviceInfo query_v4l2_device(const std::string& path) {
  V4L2DeviceInfo info;
  info.path = path;
  const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    info.error = std::strerror(err);
    if (err == EACCES) info.error += " (add your user to group 'video', then log in again)";
    return info;
  }
  v4l2_capability cap{};
  if (xioctl(fd, VIDIOC_QUERYCAP, &cap) != 0) {
    info.error = std::string("not a V4L2 device: ") + std::strerror(errno);
    ::close(fd);
    return info;
  }
  info.driver = reinterpret_cast<const char*>(cap.driver);
  info.card = reinterpret_cast<const char*>(cap.card);
  info.bus_info = reinterpret_cast<const char*>(cap.bus_info);
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  info.capture = (caps & V4L2_CAP_VIDEO_CAPTURE) && (caps & V4L2_CAP_STREAMING);
  if (info.capture) {
    v4l2_fmtdesc desc{};
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    for (desc.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &desc) == 0; ++desc.index) {
      V4L2FormatInfo format;
      format.fourcc = v4l2::fourcc_string(desc.pixelformat);
      format.description = reinterpret_cast<const char*>(desc.description);
      query_sizes(fd, format, desc.pixelformat);
      info.formats.push_back(std::move(format));
    }
    query_controls(fd, info.controls);
  }
  ::close(fd);
  return info;
}

std::vector<V4L2DeviceInfo> list_v4l2_devices(const std::string& dev_dir) {
  std::vector<std::pair<int, std::string>> nodes;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dev_dir, ec)) {
    const std::string name = entry.path().filename().string();
    // "video" + 1..9 digits: video0, video12 (not video-emu0, not videoX).
    const std::string digits = name.rfind("video", 0) == 0 ? name.substr(5) : std::string();
    if (digits.empty() || digits.size() > 9 ||
        !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    nodes.emplace_back(std::stoi(digits), entry.path().string());
  }
  std::sort(nodes.begin(), nodes.end());

  // Stable names: udev's symlinks, resolved to the node they point at.
  std::vector<std::pair<std::string, std::string>> links;  // (canonical target, link)
  for (const char* sub : {"v4l/by-id", "v4l/by-path"})
    for (const auto& entry : fs::directory_iterator(fs::path(dev_dir) / sub, ec))
      if (auto target = fs::canonical(entry.path(), ec); !ec)
        links.emplace_back(target.string(), entry.path().string());
  std::sort(links.begin(), links.end());

  std::vector<V4L2DeviceInfo> devices;
  for (const auto& [number, path] : nodes) {
    V4L2DeviceInfo info = query_v4l2_device(path);
    const std::string canonical = fs::canonical(path, ec).string();
    for (const auto& [target, link] : links)
      if (target == canonical) info.links.push_back(link);
    devices.push_back(std::move(info));
  }
  return devices;
}

}  // namespace ips
