// The one place where a camera's configuration becomes a frame source (v4l2 | file | synthetic).
// Above the stages it assembles: the synthetic source is the simulator's.
#pragma once

#include <cstdint>

#include "ips/capture/camera_settings.h"
#include "ips/capture/source_supervisor.h"
#include "ips/geometry/camera_model.h"

namespace ips {

struct SourceContext {
  /// CLOCK_MONOTONIC instant of scene time 0, shared by every synthetic camera of the daemon
  /// so that they render the same scene instant for the same capture time.
  std::int64_t synthetic_epoch_mono_ns = 0;
  /// Virtual time (`ips record --virtual-time`): synthetic and file cameras deliver every frame
  /// as fast as the reader takes it, stamped with its exact capture time from the epoch above
  /// on (nothing waits for the clock, nothing is skipped when the machine is busy). A V4L2
  /// camera cannot (make_source_factory refuses it).
  bool virtual_time = false;
};

/// Checks what can be checked at start-up (a synthetic camera's scene loads and has the
/// camera; V4L2/file options are valid) and returns the factory the supervisor calls for
/// every (re)open. Throws ips::InputError naming cameras[i].
SourceFactory make_source_factory(const CameraConfig& camera, const SourceContext& context);

/// The camera's intrinsics: its `intrinsics` file, or for a synthetic camera without one,
/// the scene camera's model. Throws ips::InputError naming the file.
CameraModel load_intrinsics(const CameraConfig& camera);

}  // namespace ips
