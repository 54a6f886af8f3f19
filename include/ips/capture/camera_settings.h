// One camera of the lab's configuration (cameras[i]): which source delivers its frames and the
// settings of that source. The per-source blocks are the sources' own option structs, so every
// default is written once, where the source is (v4l2_source.h, file_source.h). Parsed from YAML
// by src/capture/parse_camera.cpp; docs/configuration.md lists every key.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "ips/capture/file_source.h"
#include "ips/capture/v4l2_source.h"

namespace ips {

enum class SourceKind { kV4l2, kFile, kSynthetic };
const char* to_string(SourceKind kind);

/// One camera. Blocks a source does not use are ignored by it (but still type-checked).
struct CameraConfig {
  int index = -1;                         ///< position in `cameras` (= bit in the stream's camera mask)
  std::string name;                       ///< required; log prefix ("cam0: ...") and default model name
  std::string model;                      ///< camera name in the model file; default: `name`
  SourceKind source = SourceKind::kV4l2;  ///< required: v4l2 | file | synthetic
  /// v4l2: cameras[].device, width, height, pixel_format, buffer_count, controls.*. Width and
  /// height are also the frame size file frames are checked against.
  V4L2Options v4l2;
  /// file: cameras[].path, loop, preload.
  FileSourceOptions file;
  // synthetic
  std::filesystem::path scene;  ///< synthetic: the simulator's scene file; required for synthetic
  std::string scene_camera;     ///< synthetic: camera of the scene to render; default: `name`
  /// synthetic: frame k is delivered this long after its capture time, s (like MJPEG over USB);
  /// unset = one frame period. (An optional, not a NaN: NaN != NaN would make every reload see
  /// "changed cameras" and restart the camera threads.)
  std::optional<double> transport_delay_s;
  /// synthetic: frame k is captured at scene time phase + k / fps; file: a phase > 0 puts
  /// its frames at phase + k / fps on the monotonic clock; s (unsynchronised cameras)
  double phase_s = 0.0;
  // every source
  /// Frames per second requested (v4l2) or paced (file, synthetic): cameras[].fps, copied into
  /// v4l2.fps and file.fps so that the blocks agree with it.
  double fps = V4L2Options{}.fps;
  std::filesystem::path intrinsics;  ///< camera intrinsics file (CameraModel::load); required except
                                     ///< for synthetic cameras (default: the scene camera's)
  bool required = false;             ///< true: failing to open at start is fatal (exit 1)
  /// Added to the source's timestamps so that they mean mid exposure, s (may be negative;
  /// docs/cameras.md says how to measure it).
  double timestamp_offset_s = 0.0;

  bool operator==(const CameraConfig&) const = default;
};

}  // namespace ips
