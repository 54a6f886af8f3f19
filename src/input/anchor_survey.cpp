#include "ips/input/anchor_survey.h"

#include <algorithm>
#include <utility>

namespace ips {

AnchorSurveyor::AnchorSurveyor(std::vector<std::uint32_t> ids, std::vector<Eigen::Vector3d> configured)
    : ids_(std::move(ids)), configured_(std::move(configured)), anchors_(ids_.size()) {}

std::optional<AnchorEvent> AnchorSurveyor::add(std::size_t index, const Eigen::Vector3d& tag, double range_m,
                                               double sigma_m) {
  if (index >= anchors_.size()) return std::nullopt;
  PerAnchor& a = anchors_[index];
  a.window.push_back({tag, range_m, sigma_m});
  if (a.window.size() > kWindow) a.window.pop_front();
  ++a.total;
  if (++a.since_estimate < kEvery) return std::nullopt;
  // Every kEvery samples (a few ms of Ceres on the input thread, every ~20 s at 10 Hz).
  a.since_estimate = 0;
  const std::vector<AnchorSample> samples(a.window.begin(), a.window.end());
  a.estimate = calibrate_anchor_best(configured_[index], samples);
  // The verdict: only an estimate that places the anchor can say it moved; a shift within 3
  // sigma is what these ranges cannot tell from none (docs/ranging.md).
  const AnchorCalibration& e = *a.estimate;
  if (e.status != AnchorCalibration::Status::kOk || e.unknowns == AnchorUnknowns::kBias) return std::nullopt;
  const Eigen::Vector3d shift = e.position - configured_[index];
  const double sigma = e.sigma.head<3>().norm();
  const bool moved = shift.norm() > std::max(kMovedM, 3 * sigma);
  if (moved == a.moved) return std::nullopt;
  a.moved = moved;
  return AnchorEvent{moved ? AnchorEvent::Kind::kMoved : AnchorEvent::Kind::kBack, ids_[index], shift, sigma};
}

std::vector<AnchorSurvey> AnchorSurveyor::surveys() const {
  std::vector<AnchorSurvey> out;
  for (std::size_t i = 0; i < anchors_.size(); ++i)
    if (anchors_[i].total > 0) out.push_back({ids_[i], configured_[i], anchors_[i].total, anchors_[i].estimate});
  return out;
}

}  // namespace ips
