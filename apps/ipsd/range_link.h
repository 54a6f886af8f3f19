// The daemon's range input (`ranging:`, docs/ranging.md): the socket, the admission of each
// firing, its solution (RangeFixer), and the fix handed to the fusion thread's queue beside the
// cameras' frames. It outlives camera restarts (attach() follows the pipeline's queue); a
// reload that changes `ranging:` replaces it.
#pragma once

#include <memory>
#include <mutex>

#include <nlohmann/json.hpp>

#include "ips/input/range_fixer.h"
#include "ips/input/range_input.h"
#include "latest_states.h"
#include "pipeline.h"

namespace ipsd {

class RangeLink {
 public:
  /// Binds the port; throws ips::InputError naming `ranging.*` if it cannot.
  /// `latest`: the published states, where a tag ranges to another robot (outlives this).
  RangeLink(const ips::RangingConfig& config, const LatestStates& latest);
  ~RangeLink();
  RangeLink(const RangeLink&) = delete;
  RangeLink& operator=(const RangeLink&) = delete;

  /// Where fixes go from now on; nullptr while the pipeline restarts (fixes are then dropped).
  void attach(ObservationQueue* queue);
  /// The status document's `ranging` object: the input's counters and the fixes'.
  nlohmann::json status() const;
  const ips::RangingConfig& config() const { return config_; }
  std::uint16_t port() const { return input_->port(); }

 private:
  void on_firing(ips::AdmittedFiring&& firing);
  static void log_anchor(const ips::AnchorEvent& e);

  ips::RangingConfig config_;
  mutable std::mutex mutex_;  // fixer_ and queue_ (the input's thread vs attach / status)
  ips::RangeFixer fixer_;
  ObservationQueue* queue_ = nullptr;
  std::uint64_t detached_ = 0;              // fixes dropped while no pipeline ran
  std::unique_ptr<ips::RangeInput> input_;  // last: its thread calls on_firing
};

}  // namespace ipsd
