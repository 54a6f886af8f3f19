// `ips cameras`: the V4L2 cameras on this machine, with what a config needs — stable
// by-id paths, formats, sizes and frame rates; with --probe, one MJPEG frame from each says
// whether the camera sends restart markers (which make ipsd's region decodes cheap).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include <fmt/format.h>

#include "command.h"
#include "ips/capture/jpeg_restart.h"
#include "ips/capture/v4l2_devices.h"
#include "ips/capture/v4l2_source.h"

namespace cmd_cameras {  // named, not anonymous: unique in a unity build

std::string rates(const ips::V4L2FrameSize& size) {
  if (!size.fps_range.empty()) return size.fps_range;
  std::string s;
  for (double f : size.fps) s += (s.empty() ? "" : ", ") + fmt::format("{:.4g}", f);
  return s.empty() ? "rate not reported" : s + " fps";
}

// A control in the config's terms: seconds for exposure, Hz for the power line, booleans.
std::string describe_control(const ips::V4L2ControlInfo& c) {
  auto power_line = [](int v) { return v == 1 ? "50" : v == 2 ? "60" : v == 0 ? "0 (off)" : "auto"; };
  if (c.key == "exposure")
    return fmt::format("exposure: {:.4g}..{:.4g} s, now {:.4g} s", c.min * 1e-4, c.max * 1e-4, c.current * 1e-4);
  if (c.key == "auto_exposure") return fmt::format("auto_exposure: now {}", c.current != 1);
  if (c.key == "autofocus") return fmt::format("autofocus: now {}", c.current != 0);
  if (c.key == "power_line_hz") return fmt::format("power_line_hz: now {}", power_line(c.current));
  return fmt::format("{}: {}..{}, now {}", c.key, c.min, c.max, c.current);
}

// One MJPEG frame at the size a config would ask for (1920x1080 if offered, else the largest):
// does it carry restart markers? Needs the camera free (not opened by ipsd).
std::string probe_restart_markers(const ips::V4L2DeviceInfo& d) {
  const auto mjpeg =
      std::find_if(d.formats.begin(), d.formats.end(), [](const ips::V4L2FormatInfo& f) { return f.fourcc == "MJPG"; });
  if (mjpeg == d.formats.end()) return "no MJPEG format: not applicable";
  ips::V4L2Options o;
  o.device = d.path;
  o.format = ips::PixelFormat::kMjpeg;
  const auto& sizes = mjpeg->sizes;
  const bool has_1080p =
      std::any_of(sizes.begin(), sizes.end(), [](const auto& s) { return s.width == 1920 && s.height == 1080; });
  if (!has_1080p && !sizes.empty()) {
    const auto largest = std::max_element(sizes.begin(), sizes.end(), [](const auto& a, const auto& b) {
      return static_cast<long>(a.width) * a.height < static_cast<long>(b.width) * b.height;
    });
    o.width = largest->width;
    o.height = largest->height;
  }
  ips::Frame frame;
  try {
    ips::V4L2Source source(o);
    source.defer_decode(true);
    source.open();
    for (int attempt = 0; attempt < 5 && frame.jpeg.empty(); ++attempt) {
      const auto status = source.read(frame, std::chrono::milliseconds(1000));
      if (status != ips::FrameSource::ReadStatus::kFrame) frame.jpeg.clear();
    }
    source.close();
  } catch (const std::exception& e) {
    return fmt::format("cannot probe: {} (is ipsd or another program using the camera?)", e.what());
  }
  if (frame.jpeg.empty()) return "cannot probe: no MJPEG frame within 5 s";
  ips::JpegRestartLayout layout;
  std::string why;
  if (!ips::read_jpeg_restart_layout(frame.jpeg, layout, why))
    return fmt::format("cannot tell from a {}x{} frame: {}", o.width, o.height, why);
  if (layout.restart_interval == 0)
    return fmt::format("none in a {}x{} frame: a region decode Huffman-decodes every row above its region",
                       layout.width, layout.height);
  return fmt::format(
      "every {} MCUs in a {}x{} frame (a region decode can start every {} MCU row(s), {} px): "
      "region decodes skip the rows above",
      layout.restart_interval, layout.width, layout.height, layout.entry_rows, layout.entry_rows * layout.mcu_height);
}

void print_device(const ips::V4L2DeviceInfo& d, bool probe) {
  if (!d.error.empty()) {
    std::printf("%s: cannot query: %s\n", d.path.c_str(), d.error.c_str());
    return;
  }
  std::printf("%s: %s (driver %s, bus %s)\n", d.path.c_str(), d.card.c_str(), d.driver.c_str(), d.bus_info.c_str());
  for (const auto& link : d.links) std::printf("  link: %s\n", link.c_str());
  if (!d.capture) {
    std::printf(
        "  not a capture device (e.g. the metadata node of a UVC camera): not usable as a "
        "source\n");
    return;
  }
  for (const auto& f : d.formats) {
    std::printf("  %s (%s)\n", f.fourcc.c_str(), f.description.c_str());
    for (const auto& s : f.sizes) std::printf("    %dx%d @ %s\n", s.width, s.height, rates(s).c_str());
    if (!f.size_range.empty()) std::printf("    sizes %s\n", f.size_range.c_str());
  }
  if (!d.controls.empty()) std::printf("  controls:\n");
  for (const auto& c : d.controls) std::printf("    %s\n", describe_control(c).c_str());
  if (probe) std::printf("  restart markers: %s\n", probe_restart_markers(d).c_str());
}

std::function<int()> setup(CLI::App& sub) {
  auto dev_dir = std::make_shared<std::string>("/dev");
  auto probe = std::make_shared<bool>(false);
  sub.add_option("--dev-dir", *dev_dir, "where to look for video<N> nodes and v4l/by-id links")->capture_default_str();
  sub.add_flag("--probe", *probe,
               "read one MJPEG frame from each camera (it must be free: stop ipsd) and say "
               "whether it carries restart markers, which make ipsd's region decodes cheap");
  return [dev_dir, probe] {
    const auto devices = ips::list_v4l2_devices(*dev_dir);
    if (devices.empty()) {
      std::printf(
          "No V4L2 video devices in %s: no camera is plugged in, or its driver is not loaded "
          "(check `lsusb` and `dmesg`).\n",
          dev_dir->c_str());
      return 0;
    }
    int usable = 0;
    for (const auto& d : devices) {
      print_device(d, *probe);
      usable += d.error.empty() && d.capture;
    }
    std::printf(
        "\n%d capture device(s). In the config, prefer a link under %s/v4l/by-id: "
        "/dev/videoN numbers change with plug order.\n",
        usable, dev_dir->c_str());
    return 0;
  };
}

IPS_REGISTER_COMMAND("cameras", "List the V4L2 cameras: stable by-id paths, formats, sizes and frame rates", setup);

}  // namespace cmd_cameras
