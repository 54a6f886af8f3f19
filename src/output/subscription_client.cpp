#include <algorithm>

#include "ips/output/subscription.h"

namespace ips::subscription {

namespace {
constexpr std::int64_t kResendNs = 1'000'000'000;
constexpr std::int64_t kFullRetryNs = 5'000'000'000;
}  // namespace

std::optional<std::vector<std::uint8_t>> Client::due(std::int64_t now_ns) {
  if (now_ns < next_send_ns_) return std::nullopt;
  next_send_ns_ = now_ns + kResendNs;  // unless a reply reschedules it
  return encode_request(request_, psk_);
}

bool Client::on_datagram(std::span<const std::uint8_t> bytes, std::int64_t now_ns) {
  const auto reply = decode_reply(bytes);
  if (!reply) return false;
  switch (reply->status) {
    case Status::kChallenge:
      request_.cookie = reply->cookie;
      next_send_ns_ = now_ns;  // answer at once
      break;
    case Status::kAccepted:
      request_.cookie = reply->cookie;
      state_ = State::kSubscribed;
      lease_s_ = reply->lease_s;
      next_send_ns_ = now_ns + std::max<std::int64_t>(500'000'000, std::int64_t{reply->lease_s} * 1'000'000'000 / 3);
      break;
    case Status::kRefusedFull:
      state_ = State::kRefusedFull;
      next_send_ns_ = now_ns + kFullRetryNs;
      break;
    case Status::kUnsubscribed: break;
  }
  return true;
}

std::vector<std::uint8_t> Client::unsubscribe() const {
  Request r = request_;
  r.op = Op::kUnsubscribe;
  return encode_request(r, psk_);
}

}  // namespace ips::subscription
