#include "collect_cameras.h"

#include <algorithm>
#include <chrono>

#include "ips/core/error.h"
#include "ips/geometry/marker_geometry.h"

namespace ips::cli {

CameraRun open_camera(const CameraConfig& c, const DaemonConfig& config, const SourceContext& context,
                      double edge_length) {
  CameraRun run;
  run.name = c.name;
  run.model = load_intrinsics(c);
  run.fps = c.fps;
  run.edge_length = edge_length;
  run.detector = std::make_unique<Detector>(config.detection);
  run.source = make_source_factory(c, context)();
  try {
    run.source->open();
  } catch (const SourceError& e) {
    throw SourceError("camera " + c.name + ": " + e.what());
  }
  return run;
}

Capture capture(CameraRun& c, int marker, int n, std::int64_t after_ns) {
  Capture out;
  const auto limit = std::chrono::duration<double>(std::max(10.0, 4.0 * n / c.fps));
  const auto deadline = std::chrono::steady_clock::now() + limit;
  Frame f;
  while (out.frames < n) {
    if (std::chrono::steady_clock::now() > deadline) {
      out.problem = "only " + std::to_string(out.frames) + " of " + std::to_string(n) + " frames within " +
                    std::to_string(static_cast<int>(limit.count())) + " s";
      break;
    }
    FrameSource::ReadStatus status;
    try {
      status = c.source->read(f, std::chrono::milliseconds(500));
    } catch (const SourceError& e) {
      out.problem = e.what();
      c.source->close();
      try {
        c.source->open();  // for the next placement
      } catch (const std::exception&) {
      }
      break;
    }
    if (status == FrameSource::ReadStatus::kEnd) {
      out.problem = "the source ended";
      break;
    }
    if (status != FrameSource::ReadStatus::kFrame || f.t_mono_ns < after_ns) continue;
    if (f.gray.size() != c.model.size()) {
      out.problem = "frames are " + std::to_string(f.gray.cols) + "x" + std::to_string(f.gray.rows) +
                    " but the intrinsics are for " + std::to_string(c.model.size().width) + "x" +
                    std::to_string(c.model.size().height);
      break;
    }
    ++out.frames;
    for (const auto& d : c.detector->detect(f.gray, &c.model)) {
      if (d.id != marker) continue;
      const auto o = locate_marker(d, c.model, c.edge_length);
      if (o.p_cam.allFinite()) out.samples.push_back(o.p_cam);
      break;
    }
  }
  return out;
}

}  // namespace ips::cli
