// The unicast subscription protocol (byte layout in ips/output/wire.h, "Unicast subscriptions"):
// request and reply encoding shared by the daemon's output, `ips listen --subscribe` and the
// tests; subnets for `allow`; HMAC-SHA256 (libsodium).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"

namespace ips::subscription {

using Cookie = std::array<std::uint8_t, IPS_SUB_COOKIE_SIZE>;
using Mac = std::array<std::uint8_t, IPS_SUB_MAC_SIZE>;

enum class Op : std::uint8_t { kSubscribe = IPS_SUB_OP_SUBSCRIBE, kUnsubscribe = IPS_SUB_OP_UNSUBSCRIBE };
enum class Status : std::uint8_t {
  kChallenge = IPS_SUB_CHALLENGE,
  kAccepted = IPS_SUB_ACCEPTED,
  kRefusedFull = IPS_SUB_REFUSED_FULL,
  kUnsubscribed = IPS_SUB_UNSUBSCRIBED,
};

struct Request {
  Op op = Op::kSubscribe;
  WireFormat format = WireFormat::kBinary;
  bool all = true;  ///< every marker (ids ignored)
  std::uint16_t lease_s = 30;
  std::vector<std::uint32_t> ids;  ///< wanted marker ids when !all
  Cookie cookie{};                 ///< zeros = none yet
};

struct Reply {
  Status status = Status::kChallenge;
  std::uint16_t lease_s = 0;
  Cookie cookie{};
};

/// HMAC-SHA256 of `data` under `key` (any length).
Mac hmac_sha256(std::span<const std::uint8_t> key, std::span<const std::uint8_t> data);

/// A request's bytes; with a non-empty `psk` the HMAC is appended.
std::vector<std::uint8_t> encode_request(const Request& r, const std::string& psk);

enum class RequestError { kNone, kMalformed, kBadKey };
/// Decodes a request; with a non-empty `psk` it must end with a valid HMAC (compared in
/// constant time). nullopt with `error` set otherwise.
std::optional<Request> decode_request(std::span<const std::uint8_t> bytes, const std::string& psk, RequestError& error);

std::vector<std::uint8_t> encode_reply(const Reply& r);
/// nullopt if `bytes` is not a reply.
std::optional<Reply> decode_reply(std::span<const std::uint8_t> bytes);

/// An IPv4 subnet; addresses in host byte order.
struct Subnet {
  std::uint32_t network = 0;
  std::uint32_t mask = 0;
  bool contains(std::uint32_t address) const { return (address & mask) == network; }
};
/// "10.0.0.0/8", "192.168.1.7" (= /32); nullopt if malformed or host bits are set.
std::optional<Subnet> parse_subnet(const std::string& text);

/// The robot's side of the exchange, without I/O: what to send when, and what the replies
/// mean (used by `ips listen --subscribe`). Renews at a third of the lease; resends a request
/// that got no answer after a second; retries after 5 s when the daemon is full.
class Client {
 public:
  enum class State { kWaiting, kSubscribed, kRefusedFull };
  Client(Request request, std::string psk) : request_(std::move(request)), psk_(std::move(psk)) {}

  /// The request to send at monotonic time `now_ns`, if one is due.
  std::optional<std::vector<std::uint8_t>> due(std::int64_t now_ns);
  /// Handles a datagram from the daemon; false if it is not a reply (i.e. stream data).
  bool on_datagram(std::span<const std::uint8_t> bytes, std::int64_t now_ns);
  /// An unsubscribe request with the last cookie (send it when done).
  std::vector<std::uint8_t> unsubscribe() const;

  State state() const { return state_; }
  std::uint16_t lease_s() const { return lease_s_; }

 private:
  Request request_;
  std::string psk_;
  State state_ = State::kWaiting;
  std::uint16_t lease_s_ = 0;
  std::int64_t next_send_ns_ = 0;
};

}  // namespace ips::subscription
