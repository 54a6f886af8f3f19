// The cameras of an `ips collect` session, opened as the daemon opens them, and the reading
// of one placement: --frames frames captured after the Enter key, the marker located in each.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/capture/frame_source.h"
#include "ips/config/config.h"
#include "ips/config/source_factory.h"
#include "ips/detect/detector.h"
#include "ips/geometry/camera_model.h"

namespace ips::cli {

// One camera as the daemon would run it.
struct CameraRun {
  std::string name;
  CameraModel model;
  std::unique_ptr<FrameSource> source;
  std::unique_ptr<Detector> detector;
  double fps = 30.0;
  double edge_length = 0.2;
};

// Opens camera `c` of `config` as the daemon does: its intrinsics, the daemon's detector,
// its frame source (opened). `edge_length` is the marker size the caller locates.
// Throws ips::InputError (bad intrinsics/source options) or ips::SourceError naming the camera.
CameraRun open_camera(const CameraConfig& c, const DaemonConfig& config, const SourceContext& context,
                      double edge_length);

struct Capture {
  std::vector<Eigen::Vector3d> samples;  // camera coordinates, one per frame the marker was in
  int frames = 0;
  std::string problem;  // why fewer frames than asked for were read
};

// Reads `n` frames captured after `after_ns` (CLOCK_MONOTONIC) and locates `marker` in
// each. Never throws: a source error, the end of the source or a frame of the wrong size ends
// the reading early with `problem` set (a failed source is reopened for the next placement).
Capture capture(CameraRun& camera, int marker, int n, std::int64_t after_ns);

}  // namespace ips::cli
