#include "ips/config/source_factory.h"

#include <cmath>
#include <memory>

#include "ips/capture/file_source.h"
#include "ips/capture/v4l2_source.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/sim/synthetic_source.h"

namespace ips {

namespace {
std::string where(const CameraConfig& c) { return "cameras[" + std::to_string(c.index) + "]"; }

// The scene of a synthetic camera, checked to have the camera; errors name the key.
sim::Scene load_scene(const CameraConfig& c) {
  sim::Scene scene;
  try {
    scene = sim::Scene::load(c.scene);
  } catch (const InputError& e) {
    throw InputError(where(c) + ".scene: " + e.what());
  }
  try {
    (void)scene.camera_index(c.scene_camera);
  } catch (const InputError& e) {
    throw InputError(where(c) + ".scene_camera: " + e.what());
  }
  return scene;
}
}  // namespace

SourceFactory make_source_factory(const CameraConfig& c, const SourceContext& context) {
  switch (c.source) {
    case SourceKind::kSynthetic: {
      const auto scene = std::make_shared<const sim::Scene>(load_scene(c));
      sim::SyntheticSourceOptions o;
      o.camera = c.scene_camera;
      o.fps = c.fps;
      o.realtime = !context.virtual_time;  // virtual: as fast as it renders, stamped exactly
      o.epoch_mono_ns = context.synthetic_epoch_mono_ns;
      o.phase_ns = std::llround(c.phase_s * 1e9);
      o.render_ahead = o.realtime;  // the daemon's cost is measured, not the renderer's
      if (c.transport_delay_s) o.transport_delay_ns = std::llround(*c.transport_delay_s * 1e9);
      return [scene, o] { return std::make_unique<sim::SyntheticSource>(scene, o); };
    }
    case SourceKind::kV4l2: {
      if (context.virtual_time)
        throw InputError(where(c) +
                         ": a V4L2 camera runs on real time only (virtual time: synthetic and file cameras)");
      V4L2Options o = c.v4l2;
      o.fps = c.fps;
      try {
        o.validate();
      } catch (const InputError& e) {
        throw InputError(where(c) + ": " + e.what());
      }
      return [o] { return std::make_unique<V4L2Source>(o); };
    }
    case SourceKind::kFile: {
      FileSourceOptions o = c.file;
      o.fps = c.fps;
      // A phase puts the camera on the clock's grid; none (0), on its own from when it opens.
      if (context.virtual_time) {
        // Frame k at epoch + phase + k / fps, as a synthetic camera's: the cameras share a timeline.
        const std::int64_t epoch =
            context.synthetic_epoch_mono_ns != 0 ? context.synthetic_epoch_mono_ns : monotonic_ns();
        o.virtual_start_ns = epoch + std::llround(c.phase_s * 1e9);
      } else if (c.phase_s > 0) {
        o.phase_s = c.phase_s;
      }
      try {
        o.validate();
      } catch (const InputError& e) {
        throw InputError(where(c) + ": " + e.what());
      }
      return [o] { return std::make_unique<FileSource>(o); };
    }
  }
  throw InputError(where(c) + ".source: unknown source kind");  // unreachable: the enum is exhaustive
}

CameraModel load_intrinsics(const CameraConfig& c) {
  if (!c.intrinsics.empty()) {
    try {
      return CameraModel::load(c.intrinsics);
    } catch (const InputError& e) {
      throw InputError(where(c) + ".intrinsics: " + e.what());
    }
  }
  if (c.source == SourceKind::kSynthetic) {
    const sim::Scene scene = load_scene(c);
    return scene.cameras.at(scene.camera_index(c.scene_camera)).model;
  }
  throw InputError(where(c) + ".intrinsics: required key is missing");
}

}  // namespace ips
