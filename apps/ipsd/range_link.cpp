#include "range_link.h"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"

namespace ipsd {

RangeLink::RangeLink(const ips::RangingConfig& config, const LatestStates& latest)
    : config_(config), fixer_(config, [&latest](const ips::RangingTag& tag) { return latest.of(tag); }) {
  input_ = std::make_unique<ips::RangeInput>(config.input, "ranging",
                                             [this](ips::AdmittedFiring&& f) { on_firing(std::move(f)); });
}

RangeLink::~RangeLink() { input_.reset(); }  // joins the receive thread before the rest goes

void RangeLink::attach(ObservationQueue* queue) {
  std::lock_guard lock(mutex_);
  queue_ = queue;
}

void RangeLink::log_anchor(const ips::AnchorEvent& e) {
  // Once per change of verdict: an anchor that reads moved stays in `ips status` meanwhile.
  if (e.kind == ips::AnchorEvent::Kind::kMoved)
    spdlog::warn(
        "ranging: anchor {} reads {:.1f} +- {:.1f} cm from its configured position ({:+.1f} {:+.1f} {:+.1f} cm) "
        "by the ranges taken under the cameras: knocked, remounted or mistyped? (ranging.anchors, "
        "docs/ranging.md \"The daemon's anchor survey\")",
        e.anchor, 100 * e.shift.norm(), 100 * e.sigma_m, 100 * e.shift.x(), 100 * e.shift.y(), 100 * e.shift.z());
  else
    spdlog::info("ranging: anchor {} reads within {:.1f} cm of its configured position again", e.anchor,
                 100 * std::max(ips::AnchorSurveyor::kMovedM, 3 * e.sigma_m));
}

void RangeLink::on_firing(ips::AdmittedFiring&& firing) {
  // The firing's time on this host's realtime clock, from its monotonic placement.
  const std::int64_t t_real = firing.t_mono_ns + ips::realtime_minus_monotonic_ns();
  std::lock_guard lock(mutex_);
  auto observation = fixer_.fix(firing, t_real);
  for (const ips::AnchorEvent& e : fixer_.take_anchor_events()) log_anchor(e);
  if (!observation) return;
  if (!queue_) {
    ++detached_;
    return;
  }
  CameraBatch batch;
  batch.camera_index = -1;  // not a camera: fusion keys the fix by its source and tag
  batch.t_mono_ns = firing.t_mono_ns;
  batch.t_real_ns = t_real;
  if (const ips::RangingTag& tag = config_.tags.at(firing.firing.tag); tag.on_body())
    batch.body_fixes.push_back({tag.body, tag.offset, std::move(*observation)});
  else
    batch.observations.push_back(std::move(*observation));
  queue_->push(std::move(batch));
}

nlohmann::json RangeLink::status() const {
  const ips::RangeInputCounters in = input_->counters();
  std::lock_guard lock(mutex_);
  nlohmann::json refused = nlohmann::json::object();
  for (std::size_t i = 0; i < in.refused.size(); ++i)
    refused[ips::range_refusal_name(static_cast<ips::RangeRefusal>(i))] = in.refused[i];
  const ips::RangeFixCounters& fixes = fixer_.counters();
  nlohmann::json failed = nlohmann::json::object();
  for (const auto& [why, n] : fixes.failed) failed[why] = n;
  nlohmann::json ranges = nlohmann::json::object();
  for (const auto& [what, n] : fixes.ranges) ranges[what] = n;
  // Per tag: its track's restarts, late ranges replayed, and the bias it learnt per anchor
  // (beyond the configured one): a bias that stays large says the anchor's `bias` is wrong.
  nlohmann::json tracks = nlohmann::json::array();
  for (const ips::RangeTrackSummary& t : fixer_.tracks()) {
    nlohmann::json biases = nlohmann::json::object();
    for (const auto& [anchor, b] : t.biases_m) biases[std::to_string(anchor)] = b;
    tracks.push_back({{"tag", t.tag},
                      {"started", t.started},
                      {"restarts", t.restarts},
                      {"replayed", t.replayed},
                      {"learning_bias", t.learning_bias},
                      {"biases", biases}});
  }
  // Each anchor as the ranges taken under the cameras see it (track.camera_reference).
  nlohmann::json anchors = nlohmann::json::array();
  for (const ips::AnchorSurvey& a : fixer_.anchor_surveys()) {
    nlohmann::json j = {{"id", a.anchor},
                        {"samples", a.samples},
                        {"configured", {a.configured.x(), a.configured.y(), a.configured.z()}}};
    if (a.calibration) {
      const ips::AnchorCalibration& c = *a.calibration;
      j["status"] = ips::anchor_calibration_status_word(c.status);
      j["estimated"] = ips::anchor_unknowns_word(c.unknowns);
      j["position"] = {c.position.x(), c.position.y(), c.position.z()};
      j["moved_m"] = (c.position - a.configured).norm();
      j["bias_m"] = c.bias_m;
      j["sigma_m"] = {c.sigma(0), c.sigma(1), c.sigma(2), c.sigma(3)};
      j["rms_m"] = c.rms_m;
      j["outliers"] = c.outliers;
    }
    anchors.push_back(std::move(j));
  }
  return {{"port", input_->port()},
          {"datagrams", in.datagrams},
          {"accepted", in.accepted},
          {"refused", refused},
          {"unknown_references", in.unknown_references},
          {"fixes", fixes.fixes},
          {"fixes_failed", failed},
          {"mobile_references", fixes.mobile_references},
          {"mobile_references_unknown", fixes.mobile_references_unknown},
          {"track", config_.track},
          {"camera_references", fixes.camera_references},
          {"ranges", ranges},
          {"odometry", fixes.odometry},
          {"mutual", fixes.mutual},
          {"tracks", tracks},
          {"anchors", anchors},
          {"fixes_dropped_while_restarting", detached_}};
}

}  // namespace ipsd
