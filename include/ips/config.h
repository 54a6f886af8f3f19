// The daemon's configuration (YAML). Every default lives here, once, as a member initialiser;
// the README's daemon section documents each key. Loading is strict: an unknown key, a wrong
// type, a value out of range or a missing file throws ips::InputError naming the file, line,
// column and key ("ipsd.yaml:12:5: cameras[0].fps: ...").
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ips/detector.h"
#include "ips/kalman.h"
#include "ips/marker_geometry.h"
#include "ips/packet_codec.h"
#include "ips/tracker.h"

namespace ips {

struct ModelSet;

enum class SourceKind { kV4l2, kFile, kSynthetic };
/// Pixel format requested from a V4L2 camera (named apart from the capture stage's own enum).
enum class CaptureFormat { kMjpeg, kYuyv };
const char* to_string(SourceKind kind);
const char* to_string(CaptureFormat format);

/// One camera. Fields a source does not use are ignored by it (but still type-checked).
struct CameraConfig {
  int index = -1;            ///< position in `cameras` (= bit in the stream's camera mask)
  std::string name;          ///< required; log prefix ("cam0: ...") and default model name
  std::string model;         ///< camera name in the model file; default: `name`
  SourceKind source = SourceKind::kV4l2;  ///< required: v4l2 | file | synthetic
  // v4l2
  std::string device;        ///< device path, prefer /dev/v4l/by-id/...; required for v4l2
  int width = 1920;          ///< requested frame size, pixels (v4l2; file frames are checked)
  int height = 1080;
  CaptureFormat pixel_format = CaptureFormat::kMjpeg;  ///< v4l2: MJPEG | YUYV (the other is the fallback)
  int buffer_count = 4;      ///< v4l2: mmap buffers (>= 4)
  /// v4l2 controls (cameras.controls.*); unset = leave the device's setting alone.
  std::optional<bool> auto_exposure;   ///< controls.auto_exposure: true = automatic exposure
  std::optional<double> exposure_s;    ///< controls.exposure: manual exposure time, seconds
  std::optional<int> gain;             ///< controls.gain: analogue gain, device units
  std::optional<bool> autofocus;       ///< controls.autofocus
  std::optional<int> power_line_hz;    ///< controls.power_line_hz: 50 | 60 | 0 (anti-flicker off)
  // file
  std::filesystem::path path;  ///< file: a video file or a directory of images; required for file
  bool loop = true;            ///< file: start again at the end (false: the source ends -> reopened)
  bool preload = false;        ///< file (a directory): replay from memory, decode only (#12)
  // synthetic
  std::filesystem::path scene;  ///< synthetic: the simulator's scene file; required for synthetic
  std::string scene_camera;     ///< synthetic: camera of the scene to render; default: `name`
  /// synthetic: frame k is delivered this long after its capture time, s (like MJPEG over USB);
  /// NaN = one frame period.
  double transport_delay_s = std::nan("");
  /// synthetic: frame k is captured at scene time phase + k / fps, s (unsynchronised cameras)
  double phase_s = 0.0;
  // every source
  double fps = 30.0;            ///< frames per second requested (v4l2) or paced (file, synthetic)
  std::filesystem::path intrinsics;  ///< camera intrinsics file (CameraModel::load); required except
                                     ///< for synthetic cameras (default: the scene camera's)
  bool required = false;        ///< true: failing to open at start is fatal (exit 1)
  /// Added to the source's timestamps so that they mean mid exposure, s (may be negative;
  /// README "Time" says how to measure it).
  double timestamp_offset_s = 0.0;

  bool operator==(const CameraConfig&) const = default;
};

/// Per-marker settings (markers.ids.<id>).
struct MarkerInfo {
  std::string name;                              ///< optional, shown by `ips listen`
  double edge_length = std::nan("");             ///< metres; NaN = markers.edge_length
  double height = std::nan("");                  ///< known world z, metres; NaN = markers.height
};

struct MarkerConfig {
  std::string dictionary = "DICT_4X4_100";  ///< OpenCV predefined dictionary name
  double edge_length = 0.20;                ///< default printed edge length, metres
  double height = std::nan("");             ///< default known height, metres; NaN = unknown
  std::map<int, MarkerInfo> ids;

  MarkerSizes sizes() const;
  /// Known world z of marker `id` (per-ID, else the default), NaN if unknown.
  double height_of(int id) const;
};

struct OutputConfig {
  enum class Kind { kUnicast, kBroadcast, kMulticast };
  Kind kind = Kind::kUnicast;       ///< required: unicast | broadcast | multicast
  std::string address;              ///< required: IPv4 host / broadcast address / multicast group
  std::uint16_t port = 0;           ///< required: UDP port
  WireFormat format = WireFormat::kBinary;  ///< binary | json
  int ttl = 1;                      ///< multicast TTL (1 = this subnet only)
  std::string interface;            ///< multicast: IPv4 address of the sending interface; "" = default route
  std::string describe() const;     ///< "multicast 239.1.2.3:5005 (json)"

  bool operator==(const OutputConfig&) const = default;
};

struct FusionConfig {
  std::string method = "mean";  ///< mean | area | gauss | median (the per-instant combination)
  double window_s = 0.050;      ///< another camera's observation at most this old is used, motion-compensated, s
  double velocity_span_s = 0.200;  ///< a camera's own observations over this span give its velocity, s
  double history_s = 0.250;     ///< reorder buffer: observations older than this are dropped, s
  /// A marker without a known height seen by ONE camera (no triangulation): true = report the
  /// depth-formula position (z from the marker size, cm-level), false = leave it out.
  bool single_camera_depth = false;
  double output_rate_hz = 0.0;  ///< 0 = one update per camera frame; > 0 = fixed rate, state predicted
  double max_wait_s = 0.050;    ///< obsolete (frame sets are gone); accepted so old files still load
  bool kalman = false;          ///< constant-velocity Kalman filter per marker (adds velocity)
  KalmanOptions kalman_options;
};

struct StatusConfig {
  double interval_s = 10.0;  ///< one status line per camera every this many seconds; 0 = never
  std::string socket;        ///< unix stream socket for `ips status`; "" = none
};

struct DaemonConfig {
  std::filesystem::path file;  ///< where it was loaded from (for messages)
  std::vector<CameraConfig> cameras;
  MarkerConfig markers;
  /// detection: the detector's tuning; `dictionary` is copied from markers.dictionary.
  DetectorOptions detection;
  /// detection.tracking / full_search_period / roi_margin: tracking between frames (#12).
  TrackerOptions tracking;
  std::filesystem::path model_file;  ///< required
  FusionConfig fusion;
  std::vector<OutputConfig> outputs;
  std::string log_level = "info";  ///< trace | debug | info | warn | error
  StatusConfig status;
  double stall_timeout_s = 2.0;  ///< watchdog: a thread without progress this long withholds WATCHDOG=1
};

/// What loading checks beyond the format. `ips calibrate --config` loads a lab's config before
/// a camera's intrinsics file and the model file exist (calibration comes first).
struct ConfigChecks {
  bool intrinsics_exist = true;  ///< cameras[].intrinsics must name an existing file
  bool model_file_exists = true; ///< model_file must name an existing file
};

/// Parses and validates `path` (relative paths inside are resolved against its directory).
DaemonConfig load_config(const std::filesystem::path& path, ConfigChecks checks = {});
DaemonConfig parse_config(const std::string& yaml_text, const std::filesystem::path& path,
                          ConfigChecks checks = {});

/// Cross-checks the configuration against a loaded model file: every camera's model exists;
/// if a camera's mapper needs the marker height, markers.height or every listed id must give one
/// (otherwise unknown-height markers are dropped and counted at run time, see README).
/// Throws ips::InputError naming the camera key.
void check_models(const DaemonConfig& config, const ModelSet& models);

}  // namespace ips
