// The daemon's configuration (YAML), assembled from the stages' own settings: each stage owns its
// settings struct with its defaults (capture/camera_settings.h, geometry/marker_settings.h,
// detect/detector.h, fusion/fusion_settings.h, output/output_settings.h, web/web_settings.h,
// body/body.h, insideout/on_robot.h) and parses its own section (src/<stage>/parse_*.cpp); this file only puts them
// together with the daemon's own few keys. docs/configuration.md documents each key. Loading is
// strict: an unknown key, a wrong type, a value out of range or a missing file throws
// ips::InputError naming the file, line, column and key ("ipsd.yaml:12:5: cameras[0].fps: ...").
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "ips/body/body.h"
#include "ips/capture/camera_settings.h"
#include "ips/detect/detector.h"
#include "ips/detect/tracker.h"
#include "ips/fusion/fusion_settings.h"
#include "ips/geometry/marker_settings.h"
#include "ips/input/ranging_settings.h"
#include "ips/insideout/on_robot.h"
#include "ips/output/output_settings.h"
#include "ips/web/web_settings.h"

namespace ips {

struct ModelSet;

/// status.*: the periodic status lines and the socket `ips status` reads.
struct StatusConfig {
  double interval_s = 10.0;  ///< one status line per camera every this many seconds; 0 = never
  std::string socket;        ///< unix stream socket for `ips status`; "" = none
};

/// processing.*: the workers that process the cameras' frames (oldest capture first).
struct ProcessingConfig {
  int workers = 0;  ///< worker threads; 0 = one per core
  /// A frame no worker could start within this long of its delivery is dropped unprocessed and
  /// counted, s; 0 = one frame period of its camera.
  double budget_s = 0.0;

  bool operator==(const ProcessingConfig&) const = default;
};

struct DaemonConfig {
  std::filesystem::path file;  ///< where it was loaded from (for messages)
  std::vector<CameraConfig> cameras;
  MarkerConfig markers;
  /// bodies: rigid bodies made of markers (ips/body/body.h; docs/bodies.md).
  std::vector<BodyDef> bodies;
  /// detection: the detector's tuning; `dictionary` is copied from markers.dictionary.
  DetectorOptions detection;
  /// detection.tracking / full_search_period / roi_margin: tracking between frames.
  TrackerOptions tracking;
  /// cameras[i].on_robot by camera index: cameras that ride on robots and read the ceiling map
  /// (ips/insideout/on_robot.h); they need no model in model_file.
  std::map<int, OnRobotSettings> on_robot;
  std::filesystem::path model_file;  ///< required unless every camera rides on a robot
  FusionConfig fusion;
  std::vector<OutputConfig> outputs;
  std::string log_level = "info";  ///< trace | debug | info | warn | error
  ProcessingConfig processing;
  StatusConfig status;
  WebConfig web;
  RangingConfig ranging;         ///< ranging: the range input (ips/input/ranging_settings.h); absent = off
  double stall_timeout_s = 2.0;  ///< watchdog: a thread without progress this long withholds WATCHDOG=1
};

/// What loading checks beyond the format. `ips calibrate --config` loads a lab's config before
/// a camera's intrinsics file and the model file exist (calibration comes first).
struct ConfigChecks {
  bool intrinsics_exist = true;   ///< cameras[].intrinsics must name an existing file
  bool model_file_exists = true;  ///< model_file must name an existing file
};

/// Parses and validates `path` (relative paths inside are resolved against its directory).
DaemonConfig load_config(const std::filesystem::path& path, ConfigChecks checks = {});
DaemonConfig parse_config(const std::string& yaml_text, const std::filesystem::path& path, ConfigChecks checks = {});

/// Cross-checks the configuration against a loaded model file: every camera's model exists;
/// if a camera's mapper needs the marker height, markers.height or every listed id must give one
/// (otherwise unknown-height markers are dropped and counted at run time, see docs/models.md).
/// Throws ips::InputError naming the camera key.
void check_models(const DaemonConfig& config, const ModelSet& models);

}  // namespace ips
