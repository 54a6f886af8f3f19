// A simulated lab: cameras (intrinsics + pose), a textured floor, and ArUco markers that
// stand still or follow trajectories. Loaded from a scene YAML file (see docs/simulator.md).
//
// World frame: x, y on the floor (origin at one floor corner, floor spans [0, size_x] x
// [0, size_y]), z up, metres. Camera frame (OpenCV): x right in the image, y down, z along
// the optical axis. The default camera orientation looks straight down with image x along
// world x and image y along world -y: x_c = x_w, y_c = -y_w, z_c = -z_w.
#pragma once

#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/body/body.h"
#include "ips/geometry/camera_model.h"

namespace ips::sim {

/// A marker's pose in the world at some instant.
struct MarkerPose {
  double x = 0.0, y = 0.0;  ///< centre on the floor plane, metres
  double z = 0.0;           ///< height of the marker's face above the floor, metres
  double yaw = 0.0;         ///< marker x-axis heading from world +x towards +y, radians
  bool present = true;      ///< false: the marker is not in the scene (picked up), not drawn
  /// True for a marker on a body's face in any orientation: `axes` (columns: the marker's x,
  /// y and face normal in the world) then defines its plane; (x, y, z) is its centre and yaw
  /// the heading of its x axis. False: a face-up marker at height z turned by yaw.
  bool tilted = false;
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  /// Marker axes in the world (from yaw when not tilted).
  Eigen::Matrix3d frame() const;
};

/// How a marker moves. Static markers stay at their start pose.
struct Trajectory {
  enum class Kind { kStatic, kCircle, kLine, kWaypoints, kPlacements };
  Kind kind = Kind::kStatic;
  double speed = 0.0;                   ///< m/s along the path
  Eigen::Vector2d center{0, 0};         ///< circle centre, metres
  double radius = 0.0;                  ///< circle radius, metres
  bool clockwise = false;               ///< circle direction seen from above
  double start_angle = 0.0;             ///< circle: where on it at t = 0, radians from +x (centre + radius (cos, sin))
  std::vector<Eigen::Vector2d> points;  ///< line: {from, to} (back and forth); waypoints: closed loop
  bool heading_follows_path = true;     ///< yaw = direction of travel (+ yaw offset) else fixed yaw
  double pause = 0.0;  ///< waypoints: the marker stops this long at each waypoint, seconds (a wand held still)
  /// placements: the marker is put down by hand at one of these poses at a time, the one whose
  /// 0-based index the `control` file holds (read at every pose query, so whoever plays the
  /// user moves the marker by rewriting the file); anything else in it (missing file, not an
  /// index, out of range) = the marker is picked up (not present).
  std::vector<MarkerPose> placements;
  std::filesystem::path control;
};

struct SceneMarker {
  int id = 0;
  double length = 0.20;  ///< black-square edge length L, metres
  double margin = -1.0;  ///< white border around the black square, metres (<0: one cell, L/(bits+2))
  MarkerPose start;      ///< pose at t = 0 for static markers; height and yaw offset for moving ones
  Trajectory trajectory;
  int body = -1;       ///< index into Scene::bodies of the body carrying it (its pose follows the body's), or -1
  BodyMarker on_body;  ///< the marker's place on that body
};

/// A rigid body of the scene (a robot carrying a marker cube, several markers): its markers
/// are in Scene::markers (body = its index), drawn wherever the body's pose puts them.
struct SceneBody {
  BodyDef def;
  MarkerPose start;                ///< x, y of the body origin at t = 0 (z: origin height), yaw offset
  double roll = 0.0, pitch = 0.0;  ///< a fixed tilt of the body (radians), applied before yaw
  Trajectory trajectory;
};

struct SceneCamera {
  std::string name;
  std::filesystem::path intrinsics_path;
  CameraModel model;
  Eigen::Vector3d position{0, 0, 2.1};  ///< optical centre in the world, metres (riding: at t = 0)
  Eigen::Matrix3d R_wc;                 ///< columns: camera x, y, z axes in world coordinates (riding: at t = 0)
  /// `looking: up`: the camera faces the ceiling (image x along world x, image y along world y
  /// before rotation_deg); it sees the ceiling's markers (markers[].facing: down).
  bool looks_up = false;
  /// A camera that rides on a robot (inside-out, docs/inside-out.md): the robot starts at
  /// carrier_start (x, y; its heading follows the path, plus carrier_start.yaw) and follows
  /// `carrier`; the lens keeps its height (position.z) and its rotation relative to the robot
  /// (R_mount: camera axes in the robot frame, x forward, y left, z up).
  bool rides = false;
  Trajectory carrier;
  MarkerPose carrier_start;
  Eigen::Matrix3d R_mount = Eigen::Matrix3d::Identity();

  Eigen::Vector3d world_to_camera(const Eigen::Vector3d& p_world) const {
    return R_wc.transpose() * (p_world - position);
  }
  Eigen::Vector3d camera_to_world(const Eigen::Vector3d& p_cam) const { return R_wc * p_cam + position; }
};

struct Floor {
  double size_x = 4.88, size_y = 4.88;  ///< metres
  double grey = 120.0;                  ///< mean grey level (0..255) before vignetting
  double texture_contrast = 18.0;       ///< +- grey levels of the procedural texture
  double texture_scale = 0.05;          ///< texture feature size, metres
  unsigned seed = 1;
};

/// Image formation settings shared by all cameras of the scene.
struct RenderSettings {
  int supersample = 3;        ///< s x s samples per pixel on marker regions (anti-aliasing)
  double noise_sigma = 2.0;   ///< Gaussian sensor noise, grey levels
  int jpeg_quality = 90;      ///< 1..100; 0 = deliver frames without JPEG compression
  int jpeg_restart_rows = 0;  ///< a restart marker every this many MCU rows (as some cameras); 0 = none
  double vignetting = 0.35;   ///< brightness loss at the image corner (r^2 fall-off), 0..1
  double gradient = 0.15;     ///< lighting gradient across the floor along world x, +-fraction
  double exposure = 0.0;      ///< exposure time for motion blur, seconds (0 = sharp)
  int blur_samples = 5;       ///< time samples across the exposure when exposure > 0
  double white = 215.0;       ///< grey level of white marker paper at full illumination
  double black = 30.0;        ///< grey level of the black marker ink
  unsigned seed = 1;          ///< noise seed
};

/// A ceiling lamp (docs/simulator.md, "Ceiling lamps"): a bright disc (radius > 0) or
/// rectangular panel facing down at `centre`, with a glow on the ceiling around it that fades
/// over `glare_width`; seen by cameras looking up only. A distractor for the detector: never a
/// marker.
struct SceneLamp {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< x, y, height, m
  double radius = 0.0;                               ///< disc, m (0: a panel)
  double size_x = 0.0, size_y = 0.0;                 ///< panel, m (along its yaw, across)
  double yaw = 0.0;                                  ///< panel heading, rad
  double brightness = 255.0;                         ///< grey level of the lamp (saturates the sensor at 255)
  double glare = 0.4;        ///< the glow's added grey at the lamp's rim, fraction of brightness
  double glare_width = 0.3;  ///< m over which the glow fades to nothing
};

/// A ranging anchor of the scene (UWB / ultrasound, docs/simulator.md "Ranges"): every range
/// to it is the true distance + its bias + Gaussian noise (sigma) + the bias of every NLOS zone
/// the straight line crosses; beyond max_range, or with probability `dropout`, there is none.
struct SceneAnchor {
  int id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double sigma = 0.05;      ///< m
  double bias = 0.0;        ///< m, added to every range (an uncalibrated antenna delay)
  double max_range = 50.0;  ///< m
  double dropout = 0.0;     ///< probability that a firing has no range to it
};

/// An obstacle that delays ranges through it (non-line-of-sight): an axis-aligned box.
struct NlosZone {
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  double bias = 0.3;  ///< m, added to a range whose straight line crosses the box (> 0)
};

/// A ranging tag carried by a marker (at its centre, `height` above it) or by a body (at
/// `offset` in the body's frame, plus `height` along the body's z).
struct SceneTag {
  int id = 0;
  int marker = -1;   ///< the carrying marker's id (-1: on `body`)
  std::string body;  ///< the carrying body's name
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  double height = 0.0;  ///< m above the marker's centre
  /// Ranges to other tags (mobile references) within max_range, with this sigma; false: anchors only.
  bool range_tags = false;
  double sigma = 0.05;
  double max_range = 50.0;
  /// Wheel odometry: each firing also says how far the tag travelled since its previous one,
  /// with this 1-sigma (m); absent = none.
  std::optional<double> odometry;
};

/// One simulated range of a firing, with its truth.
struct SimRange {
  int reference = 0;  ///< anchor id, or tag id when is_tag
  bool is_tag = false;
  double range = 0;                                              ///< measured, m
  double sigma = 0;                                              ///< the sigma it was drawn with, m
  double true_range = 0;                                         ///< exact distance, m
  Eigen::Vector3d reference_position = Eigen::Vector3d::Zero();  ///< exact, at the firing time
};

class Scene {
 public:
  std::string dictionary = "DICT_4X4_100";
  Floor floor;
  RenderSettings render;
  std::vector<SceneCamera> cameras;
  std::vector<SceneMarker> markers;
  std::vector<SceneLamp> lamps;
  std::vector<SceneBody> bodies;
  std::vector<SceneAnchor> anchors;
  std::vector<NlosZone> nlos_zones;
  std::vector<SceneTag> tags;

  /// Loads and validates a scene file. Intrinsics paths are relative to the scene file.
  /// Throws ips::InputError naming the file, line and key.
  static Scene load(const std::filesystem::path& path);

  /// Pose of marker `index` (into `markers`) at scene time t (seconds).
  MarkerPose marker_pose_at(std::size_t index, double t) const;
  /// Exact pose of body `index` (into `bodies`) at scene time t.
  BodyPose body_pose_at(std::size_t index, double t) const;
  /// Pose of the marker with this id; throws std::out_of_range if absent.
  MarkerPose marker_pose(int id, double t) const;

  /// Exact position of tag `index` (into `tags`) at scene time t; nullopt while its marker is
  /// picked up.
  std::optional<Eigen::Vector3d> tag_position(std::size_t index, double t) const;
  /// Exact length of the path tag `index` travelled from scene time t0 to t1 (m; 0 while absent).
  double tag_travelled(std::size_t index, double t0, double t1) const;
  /// The ranges tag `index` measures when it fires at scene time t (anchors first, in file
  /// order, then other tags); `rng` draws the noise and the dropouts.
  std::vector<SimRange> fire_tag(std::size_t index, double t, std::mt19937_64& rng) const;

  /// Camera `index` at scene time t: itself, or for a riding camera its pose at t.
  SceneCamera camera_at(std::size_t index, double t) const;
  /// The robot a riding camera rides at scene time t: x, y, z (the lens height) and heading
  /// (the robot's x axis); a fixed camera's own position and the heading of its image x axis.
  MarkerPose carrier_pose_at(std::size_t index, double t) const;

  /// Index of the camera called `name`; throws ips::InputError listing the names if absent.
  std::size_t camera_index(const std::string& name) const;

  /// The standard straight-down orientation (straight up with `up`) rotated by roll, pitch, yaw
  /// (radians, about the world x, y, z axes, applied in that order).
  static Eigen::Matrix3d orientation(double roll, double pitch, double yaw, bool up = false);
};

}  // namespace ips::sim
