// `ips cameras`: the V4L2 cameras on this machine, with what a config needs — stable
// by-id paths, formats, sizes and frame rates.
#include <cstdio>
#include <string>

#include <fmt/format.h>

#include "command.h"
#include "ips/capture/v4l2_devices.h"

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

void print_device(const ips::V4L2DeviceInfo& d) {
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
}

IPS_REGISTER_COMMAND("cameras", "List the V4L2 cameras: stable by-id paths, formats, sizes and frame rates",
                     [](CLI::App& sub) -> std::function<int()> {
                       auto dev_dir = std::make_shared<std::string>("/dev");
                       sub.add_option("--dev-dir", *dev_dir, "where to look for video<N> nodes and v4l/by-id links")
                           ->capture_default_str();
                       return [dev_dir] {
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
                           print_device(d);
                           usable += d.error.empty() && d.capture;
                         }
                         std::printf(
                             "\n%d capture device(s). In the config, prefer a link under %s/v4l/by-id: "
                             "/dev/videoN numbers change with plug order.\n",
                             usable, dev_dir->c_str());
                         return 0;
                       };
                     });

}  // namespace cmd_cameras
