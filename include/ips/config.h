// The daemon's configuration (YAML). Every default lives here, once, as a member initialiser;
// the README's daemon section documents each key. Loading is strict: an unknown key, a wrong
// type, a value out of range or a missing file throws ips::InputError naming the file, line,
// column and key ("ipsd.yaml:12:5: cameras[0].fps: ...").
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ips/body.h"
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
  /// unset = one frame period. (An optional, not a NaN: NaN != NaN made every reload see
  /// "changed cameras" and restart the camera threads.)
  std::optional<double> transport_delay_s;
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
  /// A marker that stays put (a reference left on the floor): its surveyed world position,
  /// metres. ipsd checks every camera's view of it (README "survey", bumped camera).
  std::optional<std::array<double, 3>> fixed;
  bool publish = true;  ///< false: never sent to any output; default false for fixed markers
};

struct MarkerConfig {
  std::string dictionary = "DICT_4X4_100";  ///< OpenCV predefined dictionary name
  double edge_length = 0.20;                ///< default printed edge length, metres
  double height = std::nan("");             ///< default known height, metres; NaN = unknown
  std::map<int, MarkerInfo> ids;

  MarkerSizes sizes() const;
  /// Known world z of marker `id` (per-ID, else the default), NaN if unknown.
  double height_of(int id) const;
  /// False for markers configured with publish: false (fixed markers by default).
  bool published(int id) const;
};

/// One vehicle of a MAVLink output (outputs[i].vehicles[j]): the marker it carries.
struct MavlinkVehicle {
  int marker = -1;           ///< required: ArUco id of the marker on the vehicle
  int system_id = 0;         ///< required: the vehicle's MAVLink system id, 1..255
  std::string address;       ///< destination host; "" = the output's address
  std::uint16_t port = 0;    ///< destination port; 0 = the output's port
  double marker_yaw_deg = 0; ///< heading of the marker's x axis relative to the vehicle's nose, degrees (CCW)

  bool operator==(const MavlinkVehicle&) const = default;
};

/// type: mavlink (src/output/mavlink_sink.cpp; README "MAVLink").
struct MavlinkOutputSettings {
  std::vector<MavlinkVehicle> vehicles;  ///< required, non-empty
  bool vision_position_estimate = true;  ///< messages: send VISION_POSITION_ESTIMATE (#102)
  bool odometry = false;                 ///< messages: send ODOMETRY (#331)
  int component_id = 197;                ///< MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
  double rate_limit_hz = 30.0;           ///< at most this many pose messages per vehicle per second
  double yaw_offset_deg = 0.0;           ///< heading of the lab's x axis in the autopilot's frame (clockwise)
  double track_gap_s = std::nan("");     ///< unseen longer than this = new track; NaN = fusion.kalman.reset_after
  double yaw_stddev_deg = 5.0;           ///< attitude standard deviation reported in the covariance
  bool heartbeat = true;                 ///< HEARTBEAT (#0) at 1 Hz per vehicle

  bool operator==(const MavlinkOutputSettings&) const = default;
};

/// type: subscriptions (src/output/subscription_sink.cpp; protocol in include/ips/wire.h).
struct SubscriptionSettings {
  std::vector<std::string> allow = {"0.0.0.0/0"};  ///< IPv4 subnets (CIDR) that may subscribe
  std::string psk;              ///< pre-shared key for HMAC-SHA256 over requests; "" = none
  int max_subscribers = 16;     ///< verified subscribers at once
  double max_lease_s = 60.0;    ///< a longer requested lease is shortened to this

  bool operator==(const SubscriptionSettings&) const = default;
};

/// outputs[i] of type ros2: ROS 2 messages over DDS (README "ROS 2"; src/output/ros2_sink.h).
struct Ros2OutputSettings {
  int domain = 0;                  ///< DDS domain 0..232; key absent: $ROS_DOMAIN_ID if set, else 0
  std::string prefix = "ipsd";     ///< ROS namespace of the topics: /<prefix>/<name>/pose
  std::string frame_id = "world";  ///< header.frame_id of poses and odometry, the TF parent frame
  /// Odometry child_frame_id and TF child frame; "{name}" and "{id}" are replaced per marker.
  std::string child_frame_id = "{name}";
  bool pose = true;       ///< geometry_msgs/PoseStamped on <prefix>/<name>/pose
  bool odometry = true;   ///< nav_msgs/Odometry on <prefix>/<name>/odom (updates with velocity only)
  bool tf = false;        ///< tf2_msgs/TFMessage on /tf (always reliable: tf2 listeners ask for it)
  bool reliable = false;  ///< qos: best_effort (false) | reliable
  int depth = 5;          ///< keep-last history depth per topic, 1..1000
  /// Not a key: markers.ids.<id>.name of every named marker, copied at load time (the ROS name
  /// of an unnamed marker is marker_<id>).
  std::map<int, std::string> marker_names;

  bool operator==(const Ros2OutputSettings&) const = default;
};

struct OutputConfig {
  enum class Kind { kUnicast, kBroadcast, kMulticast, kMavlink, kSubscriptions, kRos2 };
  Kind kind = Kind::kUnicast;       ///< required: unicast | broadcast | multicast | mavlink | subscriptions | ros2
  std::string address;              ///< required: IPv4 host / broadcast address / multicast group
  std::uint16_t port = 0;           ///< required: UDP port
  WireFormat format = WireFormat::kBinary;  ///< binary | json
  int ttl = 1;                      ///< multicast TTL (1 = this subnet only)
  std::string interface;            ///< multicast: IPv4 address of the sending interface; "" = default route
  MavlinkOutputSettings mavlink;    ///< type mavlink (address/port: the default destination)
  SubscriptionSettings subscriptions;  ///< type subscriptions (address/port: where to listen)
  Ros2OutputSettings ros2;          ///< type ros2 only
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
  /// A camera whose view of a fixed marker is this far from its surveyed position is reported
  /// as possibly moved, metres.
  double fixed_marker_warn_m = 0.03;
};

struct StatusConfig {
  double interval_s = 10.0;  ///< one status line per camera every this many seconds; 0 = never
  std::string socket;        ///< unix stream socket for `ips status`; "" = none
};

/// The web view (web.*; README "web"): off unless `listen` is set.
struct WebConfig {
  std::string listen;          ///< "host:port" as configured; "" = no web server
  std::string host;            ///< IPv4 address to bind (from `listen`; "localhost" = 127.0.0.1)
  int port = 0;                ///< TCP port (from `listen`)
  double update_rate_hz = 20;  ///< fused updates per second sent to each browser, at most
  double camera_fps = 5;       ///< camera view frames per second per camera, at most (taken only on request)
  int image_width = 960;       ///< camera view JPEG width, pixels (frames are downscaled to it)
  int max_clients = 32;        ///< live streams at once; more get 503
  /// Connections at once besides the live streams: HTTP threads = max_connections + max_clients.
  /// A connection holds its thread from accept until answered, an idle one request_timeout_s at most.
  int max_connections = 128;
  /// Requests in progress (live streams included) from one client address at once; more get 503.
  int max_per_address = 8;
  double request_timeout_s = 1.5;  ///< seconds to send a whole request (idle sockets are closed then), and per write
  /// Floor outline drawn on the map: [xmin, ymin, xmax, ymax], metres; empty = none.
  std::vector<double> floor;

  bool operator==(const WebConfig&) const = default;
};

struct DaemonConfig {
  std::filesystem::path file;  ///< where it was loaded from (for messages)
  std::vector<CameraConfig> cameras;
  MarkerConfig markers;
  /// bodies: rigid bodies made of markers (ips/body.h; README section "bodies").
  std::vector<BodyDef> bodies;
  /// detection: the detector's tuning; `dictionary` is copied from markers.dictionary.
  DetectorOptions detection;
  /// detection.tracking / full_search_period / roi_margin: tracking between frames (#12).
  TrackerOptions tracking;
  std::filesystem::path model_file;  ///< required
  FusionConfig fusion;
  std::vector<OutputConfig> outputs;
  std::string log_level = "info";  ///< trace | debug | info | warn | error
  StatusConfig status;
  WebConfig web;
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
