#include "ips/source_factory.h"

#include <memory>

#include "ips/error.h"

#if __has_include("ips/sim/synthetic_source.h")
#include "ips/sim/synthetic_source.h"
#define IPS_HAVE_SYNTHETIC 1
#endif
#if __has_include("ips/v4l2_source.h")
#include "ips/v4l2_source.h"
#define IPS_HAVE_V4L2 1
#endif
#if __has_include("ips/file_source.h")
#include "ips/file_source.h"
#define IPS_HAVE_FILE 1
#endif

namespace ips {

namespace {
std::string where(const CameraConfig& c) { return "cameras[" + std::to_string(c.index) + "]"; }

[[noreturn]] void not_built(const CameraConfig& c) {
  throw InputError(where(c) + ".source: '" + to_string(c.source) + "' sources are not part of this build");
}

#ifdef IPS_HAVE_SYNTHETIC
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
#endif
}  // namespace

SourceFactory make_source_factory(const CameraConfig& c, const SourceContext& context) {
  switch (c.source) {
    case SourceKind::kSynthetic: {
#ifdef IPS_HAVE_SYNTHETIC
      const auto scene = std::make_shared<const sim::Scene>(load_scene(c));
      sim::SyntheticSourceOptions o;
      o.camera = c.scene_camera;
      o.fps = c.fps;
      o.realtime = true;
      o.epoch_mono_ns = context.synthetic_epoch_mono_ns;
      return [scene, o] { return std::make_unique<sim::SyntheticSource>(scene, o); };
#else
      (void)context;
      not_built(c);
#endif
    }
    case SourceKind::kV4l2: {
#ifdef IPS_HAVE_V4L2
      V4L2Options o;
      o.device = c.device;
      o.width = c.width;
      o.height = c.height;
      o.format = c.pixel_format == CaptureFormat::kMjpeg ? PixelFormat::kMjpeg : PixelFormat::kYuyv;
      o.fps = c.fps;
      o.buffer_count = c.buffer_count;
      o.controls.auto_exposure = c.auto_exposure;
      o.controls.exposure_s = c.exposure_s;
      o.controls.gain = c.gain;
      o.controls.autofocus = c.autofocus;
      o.controls.power_line_hz = c.power_line_hz;
      try {
        o.validate();
      } catch (const InputError& e) {
        throw InputError(where(c) + ": " + e.what());
      }
      return [o] { return std::make_unique<V4L2Source>(o); };
#else
      not_built(c);
#endif
    }
    case SourceKind::kFile: {
#ifdef IPS_HAVE_FILE
      FileSourceOptions o;
      o.path = c.path.string();
      o.fps = c.fps;
      o.loop = c.loop;
      try {
        o.validate();
      } catch (const InputError& e) {
        throw InputError(where(c) + ": " + e.what());
      }
      return [o] { return std::make_unique<FileSource>(o); };
#else
      not_built(c);
#endif
    }
  }
  not_built(c);
}

CameraModel load_intrinsics(const CameraConfig& c) {
  if (!c.intrinsics.empty()) {
    try {
      return CameraModel::load(c.intrinsics);
    } catch (const InputError& e) {
      throw InputError(where(c) + ".intrinsics: " + e.what());
    }
  }
#ifdef IPS_HAVE_SYNTHETIC
  if (c.source == SourceKind::kSynthetic) {
    const sim::Scene scene = load_scene(c);
    return scene.cameras.at(scene.camera_index(c.scene_camera)).model;
  }
#endif
  throw InputError(where(c) + ".intrinsics: required key is missing");
}

}  // namespace ips
