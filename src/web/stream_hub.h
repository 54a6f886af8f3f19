// The live stream's fan-out: fused updates from the fusion thread go into a bounded inbox;
// the hub's own thread merges them into a marker and a body table at most `rate` times a second, encodes
// one message and pushes it into every client's bounded queue (full: the oldest message is
// dropped and counted). Each client's queue is drained by the HTTP thread serving it, so a
// slow browser only ever delays itself.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "ips/output/packet_codec.h"

namespace ips::web {

using Message = std::shared_ptr<const std::string>;

class StreamClient {
 public:
  static constexpr std::size_t kQueue = 8;  // ~0.4 s of updates at 20 Hz
  /// Queues `m`; a full queue drops its oldest message (returns true if one was dropped).
  bool push(Message m);
  /// Waits up to `timeout_ms` for a message; nullptr on timeout or close.
  Message pop(int timeout_ms);
  void close();
  bool closed() {
    std::lock_guard lock(mutex_);
    return closed_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Message> queue_;
  bool closed_ = false;
};

class StreamHub {
 public:
  static constexpr std::size_t kInbox = 256;  // fused updates between two ticks, at most
  explicit StreamHub(double rate_hz);
  ~StreamHub();
  void publish(const Datagram& d);
  void set_status(const std::string& json);
  /// A new client (nullptr if `max_clients` are connected); its first messages are the latest
  /// status and marker table.
  std::shared_ptr<StreamClient> subscribe(std::size_t max_clients);
  void unsubscribe(const std::shared_ptr<StreamClient>& c);
  void stop();

  std::atomic<std::uint64_t> clients_total{0}, refused{0}, dropped{0}, inbox_dropped{0}, broadcasts{0};
  std::size_t clients() const;

 private:
  template <typename Record>
  struct Entry {
    Record record;
    std::int64_t t_mono_ns = 0;  ///< the record's capture time
    bool has_velocity = false;   ///< markers: the datagram's has_velocity (vx, vy measured)
  };
  void run();
  void merge(const Datagram& d);
  bool forget_old(std::int64_t now);
  void broadcast(const Message& m);
  Message markers_message(std::int64_t now) const;

  const std::int64_t period_ns_;
  mutable std::mutex mutex_;  // inbox, status, clients, stop
  std::condition_variable cv_;
  std::deque<Datagram> inbox_;
  Message status_, markers_;
  bool status_changed_ = false;
  std::list<std::shared_ptr<StreamClient>> clients_;
  bool stop_ = false;
  std::map<std::uint32_t, Entry<MarkerRecord>> table_;  // fan-out thread only
  std::map<std::string, Entry<BodyRecord>> bodies_;     // fan-out thread only
  std::uint32_t last_update_ = 0;
  std::thread thread_;
};

}  // namespace ips::web
