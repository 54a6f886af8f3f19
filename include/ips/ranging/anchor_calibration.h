#pragma once
// An anchor's range bias, and optionally its position, from ranges measured where the tag's
// position was known another way (the cameras, a motion-capture system, a tape): the
// camera-as-reference calibration Petković et al. (2016) planned. Each sample says "the tag was
// at p and the module read r"; the anchor is where, and reads that much long, for which
// |p - a| + bias best explains every r (robust weighted least squares: a Huber loss, so that
// a non-line-of-sight range pulls no harder than a few sigmas).
//
// Why positions: anchors are put up with a tape measure and a ladder; a few cm off in a
// corner is a few cm of bias that changes sign across the room, which no bias state absorbs.
#include <cstddef>
#include <span>

#include <Eigen/Core>

namespace ips {

struct AnchorSample {
  Eigen::Vector3d tag = Eigen::Vector3d::Zero();  ///< where the tag was, world frame (m)
  double range_m = 0;                             ///< what the anchor's module read (m)
  double sigma_m = 0.05;                          ///< the range's 1-sigma with the tag position's added (m), > 0
};

/// What is estimated besides the bias. A ground robot's tag moves in one plane, where an
/// anchor's height and its bias explain nearly the same ranges (the nearer the anchor is to
/// that plane, the more so): then only the horizontal position is told apart from the bias.
enum class AnchorUnknowns {
  kPosition,    ///< x, y, z and the bias
  kHorizontal,  ///< x, y and the bias; z as configured
  kBias,        ///< the bias only, at the configured position
};
const char* anchor_unknowns_word(AnchorUnknowns unknowns);  // position, horizontal, bias

struct AnchorCalibrationOptions {
  AnchorUnknowns unknowns = AnchorUnknowns::kPosition;
  double robust_sigmas = 3.0;    ///< Huber loss beyond this many sigmas; 0 = plain least squares
  std::size_t min_samples = 20;  ///< fewer: kTooFew (a bias alone needs 1)
  /// A parameter whose 1-sigma, from the samples' geometry and stated sigmas alone, exceeds
  /// this (m) is not determined by these samples: kPoorGeometry (tags all in one spot, or on a
  /// line through the anchor). The values are still returned, for what they are worth.
  double max_sigma_m = 0.05;
};

struct AnchorCalibration {
  enum class Status { kOk, kTooFew, kPoorGeometry, kFailed };
  Status status = Status::kFailed;
  AnchorUnknowns unknowns = AnchorUnknowns::kPosition;  ///< what was estimated
  Eigen::Vector3d position = Eigen::Vector3d::Zero();   ///< the configured one when not estimated
  double bias_m = 0;                                    ///< the module reads this much long
  /// 1-sigma of x, y, z, bias (m): the geometry's, scaled up by the residuals when they are
  /// larger than the stated sigmas say (never down). 0 for what was not estimated.
  Eigen::Vector4d sigma = Eigen::Vector4d::Zero();
  double rms_m = 0;          ///< residual RMS of the samples within the robust limit (m)
  std::size_t samples = 0;   ///< used
  std::size_t outliers = 0;  ///< beyond robust_sigmas at the solution (NLOS, a wrong position)
};

const char* anchor_calibration_status_word(AnchorCalibration::Status status);  // ok, too_few, poor_geometry, failed

/// Calibrates one anchor from `samples`, starting at `configured`. Samples with a non-finite
/// value or a non-positive range or sigma are left out.
AnchorCalibration calibrate_anchor(const Eigen::Vector3d& configured, std::span<const AnchorSample> samples,
                                   const AnchorCalibrationOptions& options = {});

/// The most these samples determine: the position and bias if the geometry allows, else the
/// horizontal position and bias, else the bias (options.unknowns is where it starts). The
/// result's `unknowns` says which; its status is the last one tried's.
AnchorCalibration calibrate_anchor_best(const Eigen::Vector3d& configured, std::span<const AnchorSample> samples,
                                        AnchorCalibrationOptions options = {});

}  // namespace ips
