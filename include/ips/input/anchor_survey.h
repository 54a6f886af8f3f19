// The daemon's own check of its anchors: every range a tag measures while the cameras place its
// robot is a sample of "the tag was here and the anchor read this" (ips/ranging/
// anchor_calibration.h); from the latest of them each anchor's position and its bias beyond the
// configured one are estimated again and again, and shown by `ips status` beside the configured
// values. An anchor knocked or remounted shows up as one that moved. Nothing is changed in the
// configuration: positions are the operator's to correct (docs/ranging.md, "The daemon's
// anchor survey"). Not thread-safe: owned by the range fixer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "ips/ranging/anchor_calibration.h"

namespace ips {

/// A change in an anchor's verdict, for the log: it reads moved (its estimated position is
/// further than kMovedM and 3 sigma from the configured one), or back within that.
struct AnchorEvent {
  enum class Kind { kMoved, kBack };
  Kind kind = Kind::kMoved;
  std::uint32_t anchor = 0;
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  ///< estimated - configured, m
  double sigma_m = 0;                               ///< 1-sigma of the shift's length, m
};

struct AnchorSurvey {
  std::uint32_t anchor = 0;
  Eigen::Vector3d configured = Eigen::Vector3d::Zero();
  std::uint64_t samples = 0;                     ///< gathered since the start
  std::optional<AnchorCalibration> calibration;  ///< the latest estimate (bias beyond the configured)
};

class AnchorSurveyor {
 public:
  /// Estimates use the latest kWindow samples of an anchor, again after every kEvery new ones.
  static constexpr std::size_t kWindow = 1000;
  static constexpr std::size_t kEvery = 200;

  AnchorSurveyor(std::vector<std::uint32_t> ids, std::vector<Eigen::Vector3d> configured);

  /// A shift smaller than this (m) is not called a move, however certain.
  static constexpr double kMovedM = 0.10;

  /// A range to anchor `index` (corrected by its configured bias and scale) measured with the
  /// tag at `tag`; `sigma_m` covers the range and the tag's position. Returns the anchor's
  /// event when this sample's estimate changed its verdict.
  std::optional<AnchorEvent> add(std::size_t index, const Eigen::Vector3d& tag, double range_m, double sigma_m);

  std::vector<AnchorSurvey> surveys() const;

 private:
  struct PerAnchor {
    std::deque<AnchorSample> window;
    std::uint64_t total = 0;
    std::size_t since_estimate = 0;
    std::optional<AnchorCalibration> estimate;
    bool moved = false;  // the verdict last reported
  };
  std::vector<std::uint32_t> ids_;
  std::vector<Eigen::Vector3d> configured_;
  std::vector<PerAnchor> anchors_;
};

}  // namespace ips
