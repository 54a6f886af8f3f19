// `ips sim ranges --send`: the scene's tags fire in real time and their firings go to an ipsd
// range input as real datagrams, through a transport as faulty as asked (delays, bursts, loss,
// duplicates, an unknown anchor): the synthetic ranging source the daemon's tests and a demo
// without UWB hardware use.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ips/sim/scene.h"

namespace cmd_sim_ranges {

struct TransportFaults {
  double max_delay_s = 0;   ///< each datagram held back by U(0, max_delay_s)
  double burst_s = 0;       ///< > 0: released only at the end of each slot this long, back to back
  double loss = 0;          ///< probability a datagram is never sent
  double duplicate = 0;     ///< probability it is sent twice
  int unknown_anchor = -1;  ///< >= 0: every firing also ranges to this anchor id (not configured)
};

struct SendPlan {
  std::string host;
  std::uint16_t port = 0;
  std::string psk;
  double rate_hz = 10;
  double seconds = 10;
  double scene_start_s = 0;  ///< scene time at the first firing
  /// >= 0: scene time is (CLOCK_MONOTONIC - this) / 1e9 instead, ipsd's synthetic cameras' clock
  /// (its status' synthetic_epoch_mono_ns): ranges and frames then show the same scene instant.
  std::int64_t scene_epoch_mono_ns = -1;
  unsigned seed = 1;
  std::vector<int> tags;  ///< empty = all
  TransportFaults faults;
  std::string truth_csv;  ///< "": none; else fix,tag,t,x,y,z,firing_realtime_ns
};

/// Runs for plan.seconds of wall time; prints progress every 5 s and a summary. Throws
/// ips::InputError for an address it cannot send to.
int send_ranges(const ips::sim::Scene& scene, const SendPlan& plan);

}  // namespace cmd_sim_ranges
