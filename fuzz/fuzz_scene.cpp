// Simulator scene files (ips sim, the daemon's synthetic cameras): Scene::load on any text
// returns a scene or throws ips::InputError. The fuzzed file sits at config/scenes/ of a copy of
// the intrinsics the repository's scenes name (lenses/, ../../calib_data/ou2023/), so that the
// seeds load completely and the fuzzer explores past the camera entries.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "fuzz_util.h"
#include "ips/core/error.h"
#include "ips/sim/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool lenses = [] {
    const std::filesystem::path src(IPS_SOURCE_DIR), dst = ips::fuzz::scratch();
    std::filesystem::create_directories(dst / "config/scenes");
    std::filesystem::create_directories(dst / "calib_data");
    std::filesystem::copy(src / "config/scenes/lenses", dst / "config/scenes/lenses",
                          std::filesystem::copy_options::recursive);
    std::filesystem::copy(src / "calib_data/ou2023", dst / "calib_data/ou2023",
                          std::filesystem::copy_options::recursive);
    return true;
  }();
  (void)lenses;
  const auto path = ips::fuzz::write_file("config/scenes/scene.yaml", ips::fuzz::as_text(data, size));
  try {
    const auto scene = ips::sim::Scene::load(path);
    // The scene's motion functions on the loaded values (what the renderer asks every frame).
    for (std::size_t i = 0; i < scene.markers.size() && i < 8; ++i) (void)scene.marker_pose_at(i, 1.5);
  } catch (const ips::InputError&) {
  }
  return 0;
}
