// The model file (ips fit's JSON, read by ipsd at start and on SIGHUP): load_model_file on any
// bytes gives a ModelSet or throws ips::InputError; every mapper it accepts must then predict
// (and give a world ray) without touching memory it does not own, whatever its parameters.
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "fuzz_util.h"
#include "ips/core/error.h"
#include "ips/mapping/model_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = ips::fuzz::write_file("models.json", ips::fuzz::as_text(data, size));
  try {
    const ips::ModelSet models = ips::load_model_file(path);
    for (const auto& [name, entry] : models.cameras) {
      if (!entry.mapper) continue;
      const Eigen::Vector3d cam(0.3, -0.2, 2.5);
      (void)entry.mapper->predict(cam, 0.1);
      (void)entry.mapper->predict(cam);
      Eigen::Vector3d origin, direction;
      (void)entry.mapper->world_ray(cam, origin, direction);
    }
  } catch (const ips::InputError&) {
  }
  return 0;
}
