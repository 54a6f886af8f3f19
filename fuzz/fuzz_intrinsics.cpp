// Camera intrinsics files, both forms CameraModel::load reads: the ipsd YAML form (model,
// image_width, image_height, K, D) and OpenCV FileStorage files (%YAML:1.0, read by yaml-cpp;
// XML, and a text starting with '{' written as .json, read by FileStorage). A file loads or
// throws ips::InputError; a loaded model then maps pixels both ways without faults or hangs.
#include <cstddef>
#include <cstdint>

#include "fuzz_util.h"
#include "ips/core/error.h"
#include "ips/geometry/camera_model.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool json = size > 0 && data[0] == '{';
  const auto path = ips::fuzz::write_file(json ? "intrinsics.json" : "intrinsics.yaml", ips::fuzz::as_text(data, size));
  try {
    const ips::CameraModel model = ips::CameraModel::load(path);
    const double w = model.size().width, h = model.size().height;
    for (const ips::Point2 px : {ips::Point2{w / 2, h / 2}, ips::Point2{0, 0}, ips::Point2{w - 1, h - 1}}) {
      const ips::Point2 n = model.undistort(px);
      if (n.x == n.x && n.y == n.y) (void)model.project(n);
    }
  } catch (const ips::InputError&) {
  }
  return 0;
}
