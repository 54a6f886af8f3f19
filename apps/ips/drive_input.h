// The frames of a drive of a robot's up-facing camera, for `ips localise` and `ips map`: a
// folder of images with times.csv (file,t_ns), or an `ips record` session of that camera.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "ips/core/observation.h"
#include "ips/detect/detector.h"
#include "ips/geometry/camera_model.h"

namespace ips::cli {

struct FrameInput {
  std::int64_t t_ns = 0;
  std::string file;                      ///< --images: the frame to detect in
  std::vector<MarkerDetection> markers;  ///< --session: the recorded detections
};

/// DIR/times.csv: header `file,t_ns`, one frame per row in capture order, files relative to
/// DIR. Throws ips::InputError naming file:line.
std::vector<FrameInput> read_times_csv(const std::filesystem::path& dir);

/// The session's detections of one camera (`camera` may be empty when it has only one),
/// grouped by frame; `dictionary` receives the session's. A session of that camera alone must
/// carry the fingerprint of its name and `lens` (docs/survey.md), or it was recorded with
/// another calibration: ips::InputError. A session of several cameras is not checked (its
/// fingerprint covers the other lenses too).
std::vector<FrameInput> read_session_frames(const std::filesystem::path& dir, const std::string& camera,
                                            const CameraModel& lens, std::string* dictionary = nullptr);

/// A frame's detections: as recorded, or detected in its image (whose size must be the lens').
std::vector<MarkerDetection> detections_of(const FrameInput& frame, Detector& detector, const CameraModel& camera,
                                           const std::string& intrinsics_name);

}  // namespace ips::cli
