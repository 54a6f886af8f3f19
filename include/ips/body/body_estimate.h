// Marker observations -> body poses: each marker's full pose from its four corners (planar PnP,
// both IPPE solutions), mapped to the world through the camera's pose model; which face of the
// body was seen, decided from the marker's orientation (a top face points up, a side face's
// normal is horizontal; ambiguous views rejected); then one pose per body per instant fused
// over all its markers and cameras.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ips/body/body.h"
#include "ips/core/observation.h"
#include "ips/fusion/fusion.h"
#include "ips/mapping/mapper.h"

namespace ips {

/// One solution of the planar PnP of a square marker: marker -> camera (p_cam = R p_m + t,
/// marker frame x right, y up as printed, z out of the printed face), and its RMS reprojection
/// error in normalised image units.
struct MarkerPoseSolution {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double error = 0.0;
};

/// Both solutions of IPPE on the square (a small or far marker has two poses that explain its
/// corners almost equally: the flip about the line of sight), best first. Corners are
/// normalised image coordinates in ArUco order. Empty if PnP fails.
std::vector<MarkerPoseSolution> planar_marker_poses(const std::array<Point2, 4>& corners_norm, double edge);

/// A camera's pose in the world from its mapper's rays: p_world = R_wc p_cam + centre. False
/// for mappers without a camera pose (only `plane` models have one).
struct CameraPose {
  Eigen::Matrix3d R_wc = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};
bool camera_pose_of(const Mapper& mapper, CameraPose& pose);

/// What one camera saw of one body in one frame, from one marker.
struct BodyObservation {
  int body = -1;  ///< index into the estimator's bodies
  int id = -1;    ///< marker id
  int camera_index = -1;
  FaceClass face = FaceClass::kOther;  ///< the class the view was decided to be
  /// Indices (into the body's markers) of the faces this view can be: one, or several faces
  /// that share the id and class (a cube's sides), told apart at fusion by the body's yaw.
  std::vector<int> faces;
  std::vector<double> yaws;                                  ///< body yaw for each candidate face, radians
  std::vector<Eigen::Quaterniond> qs;                        ///< body orientation for each candidate (non-ground)
  std::vector<Eigen::Vector3d> positions;                    ///< body origin for each candidate, world
  Eigen::Vector3d marker_centre = Eigen::Vector3d::Zero();   ///< world, metres
  Eigen::Vector3d marker_normal = Eigen::Vector3d::UnitZ();  ///< world, from PnP
  double area_px = 0.0;
  std::int64_t t_mono_ns = 0, t_real_ns = 0;
};

/// One body's fused pose at one instant.
struct FusedBody {
  int body = -1;
  std::string name;
  BodyPose pose;
  bool has_yaw = false;  ///< false: position only (a cube side seen with no yaw to tell its face)
  std::uint32_t camera_mask = 0;
  std::vector<int> marker_ids;  ///< ids that contributed (sorted, unique)
  int observations = 0;
  double quality = 0.0;  ///< sum of contributing pixel areas
  double spread = 0.0;   ///< largest distance of a view's body position from their fused one, m
  std::int64_t t_mono_ns = 0, t_real_ns = 0;
  /// Velocity (world, m/s) and yaw rate (rad/s about world z), set by the daemon's BodyTrack
  /// from the body's published poses (body_track.h); has_velocity false until it has two.
  bool has_velocity = false;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  bool has_yaw_rate = false;  ///< two poses with a yaw in the span
  double yaw_rate = 0.0;
  /// What placed it (ips::source_bit): the cameras, or ranges alone (a ranging tag on the body,
  /// BodyTrack::add_fix; camera_mask 0, heading held from the last measured one).
  std::uint16_t sources = source_bit(ObservationSource::kCamera);
  /// Of the position, m^2: from the cameras, BodyTrackOptions::camera_sigma_m^2 over their
  /// number plus the spread^2 per axis; from ranges, the fix's.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

struct BodyEstimatorOptions {
  double face_tolerance = 0.4363;  ///< radians (25 deg) a face normal may be off its class
  double ambiguity_ratio = 2.0;    ///< IPPE: the second solution counts while its error < ratio x best
  /// Two poses that fit different faces: a face wins when its known heights make the corners a
  /// square this many times better than the other's.
  double shape_ratio = 0.5;
  double shape_tolerance = 0.15;   ///< the chosen face's corners: RMS off the square < this x edge
  double yaw_memory_s = 1.0;       ///< a body's last yaw tells its cube sides apart this long
  double side_tolerance = 0.5236;  ///< radians (30 deg): a side's yaw must lie this near the reference
  double baseline_min = 0.10;      ///< markers this far apart (m) give the yaw by their baseline
};

class BodyEstimator {
 public:
  explicit BodyEstimator(std::vector<BodyDef> bodies, BodyEstimatorOptions options = {});

  const std::vector<BodyDef>& bodies() const { return bodies_; }
  /// Index of the body carrying marker `id`, or -1 (a plain marker).
  int body_of(int id) const;

  /// One detected marker (corners_norm and corners_px set, as locate_marker gives) of one
  /// camera -> a body observation. False (and `why` set) when the marker belongs to no body,
  /// the camera has no pose model, or the view is rejected (ambiguous, matching no face).
  bool observe(const CameraObservation& obs, const Mapper& mapper, int camera_index, std::int64_t t_mono_ns,
               std::int64_t t_real_ns, BodyObservation& out, std::string* why = nullptr) const;

  /// Fuses the observations of one instant (any bodies, any cameras) into one pose per body,
  /// sorted by body index. Remembers each body's yaw for telling cube sides apart later.
  std::vector<FusedBody> fuse(std::span<const BodyObservation> observations, const FusionMethod& method);

 private:
  std::vector<BodyDef> bodies_;
  BodyEstimatorOptions options_;
  std::map<int, int> owner_;  ///< marker id -> body index
  struct Memory {
    double yaw = 0.0;
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    std::int64_t t_ns = 0;
    bool valid = false;
  };
  std::vector<Memory> memory_;
};

}  // namespace ips
