#include "ips/input/anchor_survey.h"

#include <utility>

namespace ips {

AnchorSurveyor::AnchorSurveyor(std::vector<std::uint32_t> ids, std::vector<Eigen::Vector3d> configured)
    : ids_(std::move(ids)), configured_(std::move(configured)), anchors_(ids_.size()) {}

void AnchorSurveyor::add(std::size_t index, const Eigen::Vector3d& tag, double range_m, double sigma_m) {
  if (index >= anchors_.size()) return;
  PerAnchor& a = anchors_[index];
  a.window.push_back({tag, range_m, sigma_m});
  if (a.window.size() > kWindow) a.window.pop_front();
  ++a.total;
  if (++a.since_estimate < kEvery) return;
  // Every kEvery samples (a few ms of Ceres on the input thread, every ~20 s at 10 Hz).
  a.since_estimate = 0;
  const std::vector<AnchorSample> samples(a.window.begin(), a.window.end());
  a.estimate = calibrate_anchor_best(configured_[index], samples);
}

std::vector<AnchorSurvey> AnchorSurveyor::surveys() const {
  std::vector<AnchorSurvey> out;
  for (std::size_t i = 0; i < anchors_.size(); ++i)
    if (anchors_[i].total > 0) out.push_back({ids_[i], configured_[i], anchors_[i].total, anchors_[i].estimate});
  return out;
}

}  // namespace ips
