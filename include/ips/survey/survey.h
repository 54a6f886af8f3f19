// Camera poses without a tape measure: the `ips record` session files, the wand's still
// periods found in them, and the bundle adjustment `ips survey` runs (src/survey/).
//
// Session directory (written by `ips record`, docs/survey.md):
//   session.txt        header: "ips-record 1", config path, camera fingerprint, cameras
//   <camera>.det       one line per detected marker per frame:
//                      t_ns id x0 y0 x1 y1 x2 y2 x3 y3
//                      t_ns = capture time - session start (CLOCK_MONOTONIC, ns);
//                      corners in pixels in OpenCV ArUco order (TL, TR, BR, BL as printed).
//                      Lines starting with '#' are comments.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ips/core/observation.h"
#include "ips/geometry/camera_model.h"

namespace ips::survey {

inline constexpr const char* kSessionFormat = "ips-record";
inline constexpr int kSessionVersion = 1;

/// One marker in one frame of one camera.
struct Detection {
  std::int64_t t_ns = 0;  ///< capture time since the session start, ns
  int id = -1;
  std::array<Point2, 4> corners{};  ///< pixels
};

struct SessionCamera {
  std::string name;                   ///< the camera's name in the config
  std::string file;                   ///< its detections file, relative to the session directory
  std::vector<Detection> detections;  ///< filled by load_session
};

struct Session {
  std::filesystem::path dir;
  std::string config;       ///< the config file the session was recorded with
  std::string fingerprint;  ///< camera_fingerprint() of that config's cameras
  std::string dictionary;
  double seconds = 0.0;  ///< recorded span
  std::vector<SessionCamera> cameras;
};

/// A 16-hex-digit FNV-1a digest of the cameras' names, image sizes and intrinsics (K, D):
/// a session recorded with other cameras or lenses is refused by `ips survey`.
std::string camera_fingerprint(const std::vector<std::pair<std::string, CameraModel>>& cameras);

/// The header text of session.txt.
std::string session_header(const Session& session);
/// One detections line (no newline).
std::string detection_line(const Detection& d);
/// Reads session.txt and every camera's detections. Throws ips::InputError naming the file
/// and line of anything malformed.
Session load_session(const std::filesystem::path& dir);

/// A period in which one camera saw one marker still: its corners moved less than
/// `still_px` from their mean over the period, for at least `min_still_s`.
struct StillPeriod {
  int camera = -1;  ///< index into Session::cameras
  int id = -1;
  std::int64_t t0_ns = 0, t1_ns = 0;  ///< first and last frame
  int frames = 0;
  std::array<Point2, 4> corners{};  ///< mean corners over the period, pixels
};

struct StillOptions {
  double still_px = 0.5;     ///< every corner of every frame within this many pixels of the period's mean
  double min_still_s = 0.3;  ///< shortest still period
  int min_frames = 3;
  double max_gap_s = 0.25;  ///< a longer gap between two detections ends the period
};

/// Every camera's still periods of every marker.
std::vector<StillPeriod> find_still_periods(const Session& session, const StillOptions& options);

/// One wand pose (or a reference): still periods of one marker in several cameras whose
/// time spans overlap, so they saw the marker at the same place although the cameras are
/// not synchronised. At most one period per camera (the longest).
struct Instant {
  int id = -1;
  std::int64_t t0_ns = 0, t1_ns = 0;  ///< the overlap of its periods
  std::vector<StillPeriod> views;
};

/// Groups overlapping still periods (overlap >= min_overlap_s) into instants.
std::vector<Instant> group_instants(const std::vector<StillPeriod>& periods, double min_overlap_s);

/// A floor marker at a known position (refs.yaml), lying flat; its heading is not needed.
struct Reference {
  int id = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// The heading of the marker's printed x axis, rad (`yaw_deg` in the file): `ips map` uses
  /// it (docs/inside-out.md); `ips survey` does not.
  std::optional<double> yaw;
};

/// Reads refs.yaml: `references: [{id: 7, x: 0.5, y: 0.4, z: 0.0, yaw_deg: 90}, ...]` (z
/// optional, 0; yaw_deg optional). Throws ips::InputError naming the file, line and key, also
/// for fewer than `min_references` references (`ips survey` needs 3).
std::vector<Reference> load_references(const std::filesystem::path& path, std::size_t min_references = 3);

struct SurveyCamera {
  std::string name;   ///< config name
  std::string model;  ///< name in the model file
  CameraModel intrinsics;
};

struct SurveyInput {
  std::vector<SurveyCamera> cameras;  ///< in Session::cameras order
  std::vector<Instant> instants;      ///< wand and reference instants
  std::vector<Reference> references;
  std::map<int, double> edge_length;  ///< per marker id seen; metres
  double huber_px = 1.0;              ///< robust loss scale, pixels
  int min_shared = 3;                 ///< instants a camera must share to be chained
};

struct CameraResult {
  std::string name, model;
  Eigen::Matrix3d R_wc = Eigen::Matrix3d::Identity();  ///< columns: camera axes in the world
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();    ///< optical centre, world, metres
  double rms_px = 0.0;                                 ///< reprojection RMS of its corners, pixels
  int observations = 0;                                ///< marker views (4 corners each) used
  int references_seen = 0;
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();  ///< 1-sigma of the centre, metres (x, y, z)
  bool covariance_ok = false;
};

struct ReferenceResult {
  int id = -1;
  Eigen::Vector3d known = Eigen::Vector3d::Zero();
  /// camera name -> where that camera's surveyed pose puts the marker (ray through its
  /// centre meets z = known.z) minus the known position, metres (x, y)
  std::map<std::string, Eigen::Vector2d> residual;
  /// the same with the survey solved without this reference (leave-one-out): how well it
  /// agrees with the other references and the wand (empty if that solve failed)
  std::map<std::string, Eigen::Vector2d> left_out;
};

struct SurveyResult {
  std::vector<CameraResult> cameras;
  std::vector<ReferenceResult> references;
  /// Wand positions (marker centres) used, world metres, in time order.
  std::vector<Eigen::Vector3d> wand;
  int instants = 0;
  int iterations = 0;
  double initial_rms_px = 0.0, final_rms_px = 0.0;
};

/// Initial poses by PnP and chaining, then the bundle adjustment. Throws ips::InputError
/// on input that cannot determine the poses (no reference seen, a camera not connected to
/// the rest, too few wand instants), naming the camera or the reference.
SurveyResult run_survey(const SurveyInput& input);

/// The report image: top view of cameras, floor footprints, wand path and references.
void write_report_png(const SurveyResult& result, const SurveyInput& input, const std::filesystem::path& path);

}  // namespace ips::survey
