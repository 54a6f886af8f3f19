// The inside-out inputs a user writes or edits (`ips localise`): the ceiling map (map.json) and,
// after a NUL byte, the robot's camera file (robot.yaml). Each parses or throws ips::InputError;
// a map that parses is then localised against, from the corners its own markers would show a
// camera 2.5 m under the first of them, so that hostile coordinates, lengths and yaws reach the
// solver (IPPE seeds, Levenberg-Marquardt, covariance) and never crash or hang it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_util.h"
#include "ips/core/error.h"
#include "ips/insideout/ceiling_map.h"
#include "ips/insideout/localise.h"
#include "ips/insideout/robot_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = ips::fuzz::as_text(data, size);
  const auto nul = text.find('\0');
  const std::string map_text(text.substr(0, nul));
  if (nul != std::string_view::npos) {
    const auto path = ips::fuzz::write_file("robot.yaml", text.substr(nul + 1));
    try {
      (void)ips::load_robot_config(path);
    } catch (const ips::InputError&) {
    }
  }
  try {
    const ips::CeilingMap map = ips::CeilingMap::parse(map_text, "map.json");
    // A pinhole 1920x1080 camera looking up from 2.5 m under the first marker.
    static const ips::CameraModel lens(ips::CameraModel::Kind::kPinhole, {1920, 1080},
                                       cv::Matx33d(900, 0, 960, 0, 900, 540, 0, 0, 1), {0, 0, 0, 0});
    const Eigen::Vector3d lens_at = map.markers.front().centre - Eigen::Vector3d(0, 0, 2.5);
    std::vector<ips::MarkerDetection> seen;
    for (std::size_t i = 0; i < map.markers.size() && i < 16; ++i) {
      ips::MarkerDetection d;
      d.id = map.markers[i].id;
      const auto corners = map.markers[i].corners();
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d p = corners[k] - lens_at;  // camera axes = world axes (looking up)
        d.corners_px[k] = lens.project({p.x() / p.z(), p.y() / p.z()});
      }
      seen.push_back(d);
    }
    (void)ips::localise(seen, lens, map, ips::CameraMount{});
  } catch (const ips::InputError&) {
  }
  return 0;
}
