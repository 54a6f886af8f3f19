// What bench_soak watches from outside the daemon: the position stream (per-camera record
// arrivals, gaps, datagram sequence, recovery after a fault) and the systemd notify socket
// (READY / RELOADING / WATCHDOG=1). Header-only; used by tools/bench_soak.cpp only.
#pragma once

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "ips/core/clock.h"
#include "ips/output/packet_codec.h"
#include "loopback_udp.h"

namespace ips::soak {

/// A silence of one camera's records in the stream longer than the monitor's threshold.
struct Gap {
  int camera = 0;
  std::int64_t from_ns = 0, to_ns = 0;  ///< arrival times (CLOCK_MONOTONIC) around the silence
};

/// Waits for every camera to publish again after `after_ns` (a record captured later).
struct RecoveryProbe {
  std::int64_t after_ns = 0;
  std::vector<std::int64_t> first_arrival;  ///< per camera, 0 = not yet
  std::vector<bool> wanted;                 ///< cameras expected back
  bool done() const {
    for (std::size_t c = 0; c < wanted.size(); ++c)
      if (wanted[c] && first_arrival[c] == 0) return false;
    return true;
  }
  /// The last camera's first new record (0 while not done).
  std::int64_t recovered_ns() const {
    if (!done()) return 0;
    std::int64_t t = after_ns;
    for (std::size_t c = 0; c < wanted.size(); ++c)
      if (wanted[c]) t = std::max(t, first_arrival[c]);
    return t;
  }
};

/// Receives the daemon's unicast stream on its own thread and keeps the figures.
class StreamMonitor {
 public:
  StreamMonitor(int cameras, std::int64_t gap_threshold_ns)
      : cameras_(cameras),
        threshold_ns_(gap_threshold_ns),
        last_arrival_(static_cast<std::size_t>(cameras), 0),
        records_(static_cast<std::size_t>(cameras), 0) {}
  ~StreamMonitor() { stop(); }
  StreamMonitor(const StreamMonitor&) = delete;
  StreamMonitor& operator=(const StreamMonitor&) = delete;

  std::uint16_t port() const { return rx_.port; }
  void start() {
    thread_ = std::thread([this] { loop(); });
  }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

  /// A probe id; poll it with probe().
  std::size_t add_probe(std::int64_t after_ns, const std::vector<bool>& wanted) {
    std::lock_guard lock(mutex_);
    probes_.push_back({after_ns, std::vector<std::int64_t>(wanted.size(), 0), wanted});
    return probes_.size() - 1;
  }
  RecoveryProbe probe(std::size_t id) const {
    std::lock_guard lock(mutex_);
    return probes_.at(id);
  }

  struct Totals {
    std::uint64_t datagrams = 0, malformed = 0, sequence_lost = 0, sequence_back = 0;
    std::vector<std::uint64_t> records;  ///< per camera (a fused record counts for each camera)
    std::int64_t widest_silence_ns = 0;  ///< of the whole stream (any datagram)
    std::int64_t last_datagram_ns = 0;
  };
  Totals totals() const {
    std::lock_guard lock(mutex_);
    Totals t = totals_;
    t.records = records_;
    return t;
  }
  std::vector<Gap> gaps() const {
    std::lock_guard lock(mutex_);
    return gaps_;
  }

 private:
  void loop() {
    std::vector<std::uint8_t> buf(65536);
    while (running_) {
      pollfd p{rx_.fd, POLLIN, 0};
      if (::poll(&p, 1, 100) != 1) continue;
      const ssize_t n = ::recv(rx_.fd, buf.data(), buf.size(), 0);
      const std::int64_t now = ips::monotonic_ns();
      if (n <= 0) continue;
      std::lock_guard lock(mutex_);
      try {
        const auto d = ips::decode_datagram(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)));
        on_datagram(d, now);
      } catch (const std::exception&) {
        ++totals_.malformed;
      }
    }
  }

  void on_datagram(const ips::Datagram& d, std::int64_t now) {
    ++totals_.datagrams;
    if (totals_.last_datagram_ns != 0)
      totals_.widest_silence_ns = std::max(totals_.widest_silence_ns, now - totals_.last_datagram_ns);
    totals_.last_datagram_ns = now;
    // The sequence restarts only when the outputs are rebuilt (a reload changing them; the
    // soak's good reloads keep them), so a jump forward is a datagram lost on the way.
    if (have_sequence_) {
      if (d.sequence > last_sequence_ + 1) totals_.sequence_lost += d.sequence - last_sequence_ - 1;
      if (d.sequence <= last_sequence_) ++totals_.sequence_back;
    }
    have_sequence_ = true;
    last_sequence_ = d.sequence;
    for (const auto& m : d.markers) {
      const std::int64_t capture = d.capture_monotonic_ns + 1000LL * m.dt_us;
      for (int c = 0; c < cameras_; ++c) {
        if (!((m.camera_mask >> c) & 1u)) continue;
        const auto k = static_cast<std::size_t>(c);
        ++records_[k];
        if (last_arrival_[k] != 0 && now - last_arrival_[k] > threshold_ns_)
          gaps_.push_back({c, last_arrival_[k], now});
        last_arrival_[k] = now;
        for (auto& p : probes_)
          if (p.first_arrival[k] == 0 && capture > p.after_ns) p.first_arrival[k] = now;
      }
    }
  }

  int cameras_;
  std::int64_t threshold_ns_;
  ips::support::UdpReceiver rx_;
  std::atomic<bool> running_{true};
  std::thread thread_;
  mutable std::mutex mutex_;
  std::vector<std::int64_t> last_arrival_;
  std::vector<std::uint64_t> records_;
  std::vector<Gap> gaps_;
  std::vector<RecoveryProbe> probes_;
  Totals totals_;
  bool have_sequence_ = false;
  std::uint32_t last_sequence_ = 0;
};

/// A fake systemd notify socket (NOTIFY_SOCKET): records the time of every message kind.
class NotifyListener {
 public:
  /// `watchdog_ns`: WATCHDOG_USEC as given to the daemon; a longer interval between two pings
  /// is a missed ping (systemd would have killed the daemon).
  NotifyListener(const std::string& path, std::int64_t watchdog_ns) : path_(path), watchdog_ns_(watchdog_ns) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    if (path.size() >= sizeof a.sun_path) throw std::runtime_error("notify socket path too long: " + path);
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    ::unlink(path.c_str());
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0)
      throw std::runtime_error("cannot bind " + path + ": " + std::strerror(errno));
    thread_ = std::thread([this] { loop(); });
  }
  ~NotifyListener() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  NotifyListener(const NotifyListener&) = delete;
  NotifyListener& operator=(const NotifyListener&) = delete;

  struct Figures {
    std::uint64_t pings = 0, missed = 0, ready = 0, reloading = 0, stopping = 0;
    std::int64_t first_ping_ns = 0, last_ping_ns = 0, widest_ping_interval_ns = 0;
  };
  Figures figures() const {
    std::lock_guard lock(mutex_);
    return f_;
  }

 private:
  void loop() {
    char buf[4096];
    while (running_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) != 1) continue;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) continue;
      const std::string msg(buf, static_cast<std::size_t>(n));
      const std::int64_t now = ips::monotonic_ns();
      std::lock_guard lock(mutex_);
      // One message may carry several assignments, one per line.
      auto has = [&](const char* kv) {
        return ("\n" + msg + "\n").find(std::string("\n") + kv + "\n") != std::string::npos;
      };
      if (has("WATCHDOG=1")) {
        if (f_.last_ping_ns != 0) {
          f_.widest_ping_interval_ns = std::max(f_.widest_ping_interval_ns, now - f_.last_ping_ns);
          f_.missed += now - f_.last_ping_ns > watchdog_ns_;
        }
        if (f_.first_ping_ns == 0) f_.first_ping_ns = now;
        f_.last_ping_ns = now;
        ++f_.pings;
      }
      f_.ready += has("READY=1");
      f_.reloading += has("RELOADING=1");
      f_.stopping += has("STOPPING=1");
    }
  }

  std::string path_;
  std::int64_t watchdog_ns_;
  int fd_ = -1;
  std::atomic<bool> running_{true};
  std::thread thread_;
  mutable std::mutex mutex_;
  Figures f_;
};

}  // namespace ips::soak
