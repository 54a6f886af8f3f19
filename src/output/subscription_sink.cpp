#include "subscription_sink.h"

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <sodium.h>
#include <spdlog/spdlog.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/core/udp_listener.h"

namespace ips {

namespace {

constexpr std::int64_t kSecretPeriodNs = 30'000'000'000;  // cookies live 30-60 s
constexpr std::size_t kMaxLogged = 4096;                  // distinct (reason, source) pairs logged, then quiet
const char* const kRefusalNames[] = {"refused_malformed", "refused_subnet", "refused_key", "refused_cookie",
                                     "refused_full"};

std::string endpoint(const sockaddr_in& a) {
  char ip[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &a.sin_addr, ip, sizeof ip);
  return std::string(ip) + ":" + std::to_string(ntohs(a.sin_port));
}

}  // namespace

SubscriptionSink::Key SubscriptionSink::key_of(const sockaddr_in& a) {
  return (static_cast<Key>(ntohl(a.sin_addr.s_addr)) << 16) | ntohs(a.sin_port);
}

SubscriptionSink::SubscriptionSink(const OutputConfig& c, const std::string& where) : config_(c) {
  if (sodium_init() < 0) throw std::runtime_error(where + ": libsodium cannot initialise");
  stats_.description = c.describe();
  for (std::size_t i = 0; i < c.subscriptions.allow.size(); ++i) {
    const auto s = subscription::parse_subnet(c.subscriptions.allow[i]);
    if (!s)
      throw InputError(where + ".allow[" + std::to_string(i) + "]: '" + c.subscriptions.allow[i] +
                       "' is not an IPv4 subnet");
    allow_.push_back(*s);
  }
  fd_ = open_udp_listener(c.address, c.port, where);
  for (auto& s : secrets_) randombytes_buf(s.data(), s.size());
  secret_since_ns_ = monotonic_ns();
  thread_ = start_thread_without_signals([this] { receive_loop(); });
}

SubscriptionSink::~SubscriptionSink() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  ::close(fd_);
}

subscription::Cookie SubscriptionSink::cookie_for(const sockaddr_in& from, int secret) const {
  std::uint8_t who[6];
  std::memcpy(who, &from.sin_addr.s_addr, 4);
  std::memcpy(who + 4, &from.sin_port, 2);
  const subscription::Mac mac = subscription::hmac_sha256(secrets_[static_cast<std::size_t>(secret)], who);
  subscription::Cookie c;
  std::copy_n(mac.begin(), c.size(), c.begin());
  return c;
}

bool SubscriptionSink::cookie_valid(const subscription::Cookie& c, const sockaddr_in& from) {
  for (int s = 0; s < 2; ++s) {
    const subscription::Cookie want = cookie_for(from, s);
    if (sodium_memcmp(want.data(), c.data(), c.size()) == 0) return true;
  }
  return false;
}

void SubscriptionSink::receive_loop() {
  std::vector<std::uint8_t> buf(2048);
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    const int rc = ::poll(&p, 1, 200);
    const std::int64_t now = monotonic_ns();
    if (now - secret_since_ns_ >= kSecretPeriodNs) {
      secrets_[1] = secrets_[0];
      randombytes_buf(secrets_[0].data(), secrets_[0].size());
      secret_since_ns_ = now;
    }
    {
      std::lock_guard lock(mutex_);
      expire_locked(now);
    }
    if (rc <= 0) continue;
    // Drain what is queued (a flood is handled in bulk, not one poll per datagram).
    for (int i = 0; i < 4096 && !stop_; ++i) {
      sockaddr_in from{};
      socklen_t len = sizeof from;
      const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &len);
      if (n < 0) break;
      handle(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)), from);
    }
  }
}

void SubscriptionSink::handle(std::span<const std::uint8_t> bytes, const sockaddr_in& from) {
  const std::uint32_t address = ntohl(from.sin_addr.s_addr);
  auto count_in = [&] {
    std::lock_guard lock(mutex_);
    unverified_bytes_in_ += bytes.size();
  };
  if (!std::any_of(allow_.begin(), allow_.end(), [&](const subscription::Subnet& s) { return s.contains(address); })) {
    count_in();
    return refuse(kSubnet, from, "not in outputs allow");
  }
  subscription::RequestError error;
  const auto request = subscription::decode_request(bytes, config_.subscriptions.psk, error);
  if (!request) {
    count_in();
    return refuse(error == subscription::RequestError::kBadKey ? kKey : kMalformed, from,
                  error == subscription::RequestError::kBadKey ? "wrong or missing pre-shared key HMAC"
                                                               : "not a subscription request");
  }
  const bool zero_cookie =
      std::all_of(request->cookie.begin(), request->cookie.end(), [](std::uint8_t b) { return b == 0; });
  if (zero_cookie || !cookie_valid(request->cookie, from)) {
    count_in();
    if (!zero_cookie) refuse(kCookie, from, "stale or forged cookie (challenged again)");
    // The challenge is never larger than the request: a forged source gains nothing.
    subscription::Reply challenge{subscription::Status::kChallenge, 0, cookie_for(from, 0)};
    {
      std::lock_guard lock(mutex_);
      ++challenges_;
    }
    return reply(challenge, from, false);
  }

  // Verified: the source address received our cookie and echoed it.
  const Key key = key_of(from);
  const std::int64_t now = monotonic_ns();
  subscription::Reply r{subscription::Status::kAccepted, 0, cookie_for(from, 0)};
  bool full = false, added = false;
  {
    std::lock_guard lock(mutex_);
    expire_locked(now);
    auto it = subscribers_.find(key);
    if (request->op == subscription::Op::kUnsubscribe) {
      if (it != subscribers_.end()) subscribers_.erase(it);
      r.status = subscription::Status::kUnsubscribed;
    } else if (it == subscribers_.end() &&
               subscribers_.size() >= static_cast<std::size_t>(config_.subscriptions.max_subscribers)) {
      full = true;
      r.status = subscription::Status::kRefusedFull;
    } else {
      added = it == subscribers_.end();
      Subscriber& s = subscribers_[key];
      s.to = from;
      s.format = request->format;
      s.all = request->all;
      s.ids = std::set<std::uint32_t>(request->ids.begin(), request->ids.end());
      const double lease = std::min<double>(request->lease_s, config_.subscriptions.max_lease_s);
      r.lease_s = static_cast<std::uint16_t>(std::max(1.0, lease));
      s.expires_ns = now + static_cast<std::int64_t>(r.lease_s) * 1'000'000'000;
      ++accepted_;
    }
  }
  if (full) refuse(kFull, from, "max_subscribers reached");
  if (added)
    spdlog::info("output {}: {} subscribed ({}, {}, lease {} s)", stats_.description, endpoint(from),
                 to_string(request->format),
                 request->all ? "all markers" : std::to_string(request->ids.size()) + " id(s)", r.lease_s);
  if (request->op == subscription::Op::kUnsubscribe)
    spdlog::info("output {}: {} unsubscribed", stats_.description, endpoint(from));
  reply(r, from, true);
}

void SubscriptionSink::reply(const subscription::Reply& r, const sockaddr_in& to, bool verified) {
  const std::vector<std::uint8_t> bytes = subscription::encode_reply(r);
  const ssize_t n =
      ::sendto(fd_, bytes.data(), bytes.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  std::lock_guard lock(mutex_);
  if (n != static_cast<ssize_t>(bytes.size())) {
    ++stats_.send_errors;
    return;
  }
  if (!verified) unverified_bytes_out_ += bytes.size();
}

void SubscriptionSink::refuse(Refusal why, const sockaddr_in& from, const std::string& detail) {
  {
    std::lock_guard lock(mutex_);
    ++refused_[why];
  }
  // Logged once per (reason, source address): a flood cannot fill the journal.
  const std::uint32_t address = ntohl(from.sin_addr.s_addr);
  if (logged_.size() > kMaxLogged || logged_.count({why, address})) return;
  logged_.insert({why, address});
  if (logged_.size() > kMaxLogged)
    spdlog::warn("output {}: refusals from more than {} sources; no more are logged (see the status counters)",
                 stats_.description, kMaxLogged);
  else
    spdlog::warn("output {}: refused a request from {}: {} (logged once per source)", stats_.description,
                 endpoint(from), detail);
}

void SubscriptionSink::expire_locked(std::int64_t now) {
  for (auto it = subscribers_.begin(); it != subscribers_.end();) {
    if (now >= it->second.expires_ns) {
      spdlog::info("output {}: lease of {} expired", stats_.description, endpoint(it->second.to));
      ++expired_;
      it = subscribers_.erase(it);
    } else {
      ++it;
    }
  }
}

void SubscriptionSink::publish(const Datagram& update) {
  std::lock_guard lock(mutex_);
  expire_locked(monotonic_ns());
  for (auto& entry : subscribers_) {  // not a structured binding: the lambda captures s (Clang 14)
    auto& s = entry.second;
    Datagram mine = update;
    // Init-capture: clang 14 cannot capture a structured binding itself.
    if (!s.all) {
      std::erase_if(mine.markers, [&ids = s.ids](const MarkerRecord& m) { return !ids.count(m.id); });
      // A body goes to whoever asked for one of the marker ids listed in its record.
      std::erase_if(mine.bodies, [&ids = s.ids](const BodyRecord& b) {
        return std::none_of(b.ids.begin(), b.ids.end(), [&](std::uint32_t id) { return ids.count(id) > 0; });
      });
    }
    for (Datagram& d : split_update(mine, s.format)) {
      d.sequence = s.sequence++;
      d.publish_realtime_ns = realtime_ns();
      const std::vector<std::uint8_t> bytes = encode(d, s.format);
      const ssize_t n = ::sendto(fd_, bytes.data(), bytes.size(), MSG_DONTWAIT,
                                 reinterpret_cast<const sockaddr*>(&s.to), sizeof s.to);
      if (n == static_cast<ssize_t>(bytes.size())) {
        ++stats_.datagrams;
        stats_.bytes += bytes.size();
        last_latency_ns_ = d.publish_realtime_ns - d.capture_realtime_ns;
      } else {
        ++stats_.send_errors;
      }
    }
  }
}

OutputStats SubscriptionSink::stats() const {
  std::lock_guard lock(mutex_);
  OutputStats s = stats_;
  s.counters.emplace_back("subscribers", subscribers_.size());
  s.counters.emplace_back("accepted", accepted_);
  s.counters.emplace_back("expired", expired_);
  s.counters.emplace_back("challenges", challenges_);
  for (int i = 0; i < kRefusalCount; ++i)
    s.counters.emplace_back(kRefusalNames[i], refused_[static_cast<std::size_t>(i)]);
  s.counters.emplace_back("unverified_bytes_in", unverified_bytes_in_);
  s.counters.emplace_back("unverified_bytes_out", unverified_bytes_out_);
  return s;
}

}  // namespace ips
