// Internal to src/survey: the observations of the bundle adjustment and their initial guess.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "ips/survey/survey.h"

namespace ips::survey::detail {

/// One camera's view of one instant: the four corners as unit rays in the camera frame.
struct View {
  int camera = -1;
  std::array<Eigen::Vector3d, 4> ray;                  ///< unit viewing rays of the mean corners
  Eigen::Matrix3d R_cm = Eigen::Matrix3d::Identity();  ///< marker -> camera, from PnP
  Eigen::Vector3d t_cm = Eigen::Vector3d::Zero();      ///< marker centre in the camera frame
};

/// One marker pose to solve for (a wand instant) or a reference (centre known).
struct Target {
  int id = -1;
  double edge = 0.2;
  int reference = -1;  ///< index into SurveyInput::references, -1 for the wand
  std::vector<View> views;
};

/// The marker's corners in its own frame (x right, y up as printed, z out of the face):
/// OpenCV ArUco order TL, TR, BR, BL, i.e. the object points of SOLVEPNP_IPPE_SQUARE.
std::array<Eigen::Vector3d, 4> marker_corners(double edge);

/// The targets: every instant with a view in >= 2 cameras, and every reference seen; each
/// view's rays (through the camera's intrinsics) and its PnP pose.
std::vector<Target> make_targets(const SurveyInput& input);

/// Camera poses (world -> camera: x_c = R_cw (x_w - centre)) by chaining per-view PnP
/// through shared instants, then moved onto the references. Throws ips::InputError.
void initial_poses(const SurveyInput& input, const std::vector<Target>& targets, std::vector<Eigen::Matrix3d>& R_cw,
                   std::vector<Eigen::Vector3d>& centre);

}  // namespace ips::survey::detail
