// The range input's socket: a UDP port where robots (or bridges for their UWB / ultrasound
// modules) send one datagram per firing (ips/input/range_wire.h). A receive thread admits each
// datagram (RangeAdmission: subnet, rate, key, format, tag, references, clock, duplicates,
// order) and hands the firings taken to `on_firing`, on that thread.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "ips/input/range_admission.h"

namespace ips {

class RangeInput {
 public:
  using Handler = std::function<void(AdmittedFiring&&)>;
  /// Binds address:port (throws ips::InputError naming `where` if it cannot) and starts the
  /// receive thread, which blocks every signal.
  RangeInput(const RangeInputSettings& settings, const std::string& where, Handler on_firing);
  ~RangeInput();
  RangeInput(const RangeInput&) = delete;
  RangeInput& operator=(const RangeInput&) = delete;

  RangeInputCounters counters() const;
  std::uint16_t port() const { return port_; }  ///< the bound port (the settings' port, or the one picked for 0)

 private:
  void receive_loop();

  RangeAdmission admission_;  // receive thread only, except counters (under mutex_)
  Handler on_firing_;
  int fd_ = -1;
  std::uint16_t port_ = 0;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::thread thread_;
};

}  // namespace ips
