// type: subscriptions — robots subscribe over UDP and get their own unicast stream
// (protocol in include/ips/output/wire.h; docs/subscriptions.md). A receive thread answers requests;
// publish() sends to the verified subscribers with non-blocking sendto from the same socket.
//
// Safe by construction: no stream and no reply larger than the request before the source
// address has echoed a cookie (a keyed hash of its address and port under a secret that
// rotates every 30 s), so a forged source address gets at most one reply of the request's
// size; `allow` subnets, an optional pre-shared key (HMAC-SHA256), max_subscribers and leases.
#pragma once

#include <netinet/in.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "ips/output/output_sink.h"
#include "ips/output/subscription.h"

namespace ips {

class SubscriptionSink final : public OutputSink {
 public:
  SubscriptionSink(const OutputConfig& config, const std::string& where);
  ~SubscriptionSink() override;
  SubscriptionSink(const SubscriptionSink&) = delete;
  SubscriptionSink& operator=(const SubscriptionSink&) = delete;

  void publish(const Datagram& update) override;
  OutputStats stats() const override;
  std::int64_t last_latency_ns() const override { return last_latency_ns_.load(); }

 private:
  // Why a request was not served; each is a status counter and logged once per source.
  enum Refusal { kMalformed, kSubnet, kKey, kCookie, kFull, kRefusalCount };
  struct Subscriber {
    sockaddr_in to{};
    WireFormat format = WireFormat::kBinary;
    bool all = true;
    std::set<std::uint32_t> ids;
    std::int64_t expires_ns = 0;
    std::uint32_t sequence = 0;
  };
  using Key = std::uint64_t;  // address << 16 | port
  static Key key_of(const sockaddr_in& a);

  void receive_loop();
  void handle(std::span<const std::uint8_t> bytes, const sockaddr_in& from);
  subscription::Cookie cookie_for(const sockaddr_in& from, int secret) const;
  bool cookie_valid(const subscription::Cookie& c, const sockaddr_in& from);
  void reply(const subscription::Reply& r, const sockaddr_in& to, bool verified);
  void refuse(Refusal why, const sockaddr_in& from, const std::string& detail);
  void expire_locked(std::int64_t now);

  OutputConfig config_;
  std::vector<subscription::Subnet> allow_;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;

  // Receive thread only.
  std::array<std::array<std::uint8_t, 32>, 2> secrets_{};  // [current, previous]
  std::int64_t secret_since_ns_ = 0;
  std::set<std::pair<int, std::uint32_t>> logged_;  // (refusal, source address) already logged

  mutable std::mutex mutex_;  // guards everything below (held briefly by both threads)
  std::map<Key, Subscriber> subscribers_;
  OutputStats stats_;
  std::array<std::uint64_t, kRefusalCount> refused_{};
  std::uint64_t challenges_ = 0, accepted_ = 0, expired_ = 0;
  std::uint64_t unverified_bytes_in_ = 0, unverified_bytes_out_ = 0;
  std::atomic<std::int64_t> last_latency_ns_{0};
};

}  // namespace ips
