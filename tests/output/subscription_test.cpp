// The subscriptions output on loopback: the protocol codec (HMAC against RFC 4231), subscribe /
// renew / expire, unverified and spoofed sources, a request flood, subnets, the pre-shared key
// and the subscriber limit. The "daemon" here is the real SubscriptionSink in this process.
#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <map>
#include <thread>

#include <gtest/gtest.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/output/output_sink.h"
#include "ips/output/subscription.h"

namespace ips {
namespace {

using namespace ips::subscription;

// A client socket bound to `ip` (any 127.0.0.0/8 address works on Linux loopback).
struct Peer {
  int fd = -1;
  sockaddr_in self{};
  explicit Peer(const char* ip = "127.0.0.1") {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    const int rcvbuf = 4 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    self.sin_family = AF_INET;
    ::inet_pton(AF_INET, ip, &self.sin_addr);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&self), sizeof self), 0);
    socklen_t len = sizeof self;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&self), &len);
  }
  ~Peer() { ::close(fd); }
  void send(const std::vector<std::uint8_t>& b, std::uint16_t port) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(b.size()));
  }
  std::optional<std::vector<std::uint8_t>> receive(int timeout_ms) const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) != 1) return std::nullopt;
    std::vector<std::uint8_t> buf(65536);
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n < 0) return std::nullopt;
    buf.resize(static_cast<std::size_t>(n));
    return buf;
  }
  // Everything that arrives until 300 ms pass quietly.
  std::vector<std::vector<std::uint8_t>> drain() const {
    std::vector<std::vector<std::uint8_t>> out;
    while (auto d = receive(300)) out.push_back(std::move(*d));
    return out;
  }
  std::optional<Reply> reply(int timeout_ms = 2000) const {
    auto d = receive(timeout_ms);
    return d ? decode_reply(*d) : std::nullopt;
  }
};

std::uint16_t free_port() {
  Peer p;
  return ntohs(p.self.sin_port);
}

OutputConfig subscriptions_on(std::uint16_t port) {
  OutputConfig o;
  o.kind = OutputConfig::Kind::kSubscriptions;
  o.address = "127.0.0.1";
  o.port = port;
  return o;
}

Datagram update_with(std::vector<std::uint32_t> ids) {
  Datagram d;
  d.capture_realtime_ns = realtime_ns();
  d.capture_monotonic_ns = monotonic_ns();
  for (std::uint32_t id : ids) {
    MarkerRecord m;
    m.id = id;
    m.x = id * 0.5;
    d.markers.push_back(m);
  }
  return d;
}

std::uint64_t counter(const OutputStats& s, const std::string& name) {
  for (const auto& [k, v] : s.counters)
    if (k == name) return v;
  ADD_FAILURE() << "no counter " << name;
  return 0;
}

// The full exchange from `peer`; returns the accepted reply.
std::optional<Reply> subscribe(const Peer& peer, std::uint16_t port, Request r, const std::string& psk = "") {
  r.cookie = {};
  const auto first = encode_request(r, psk);
  peer.send(first, port);
  const auto challenge = peer.receive(2000);
  if (!challenge) return std::nullopt;
  EXPECT_LE(challenge->size(), first.size()) << "the first reply must not be larger than the request";
  const auto c = decode_reply(*challenge);
  if (!c || c->status != Status::kChallenge) return c;
  r.cookie = c->cookie;
  peer.send(encode_request(r, psk), port);
  return peer.reply();
}

TEST(SubscriptionProtocol, HmacMatchesRfc4231AndRequestsRoundTrip) {
  const std::string key = "Jefe", data = "what do ya want for nothing?";
  const Mac mac = hmac_sha256({reinterpret_cast<const std::uint8_t*>(key.data()), key.size()},
                              {reinterpret_cast<const std::uint8_t*>(data.data()), data.size()});
  const std::uint8_t want[32] = {0x5b, 0xdc, 0xc1, 0x46, 0xbf, 0x60, 0x75, 0x4e, 0x6a, 0x04, 0x24,
                                 0x26, 0x08, 0x95, 0x75, 0xc7, 0x5a, 0x00, 0x3f, 0x08, 0x9d, 0x27,
                                 0x39, 0x83, 0x9d, 0xec, 0x58, 0xb9, 0x64, 0xec, 0x38, 0x43};
  EXPECT_TRUE(std::equal(mac.begin(), mac.end(), want));  // RFC 4231 test case 2

  Request r;
  r.all = false;
  r.ids = {7, 0xFFFFFFFFu};
  r.format = WireFormat::kJson;
  r.lease_s = 45;
  r.cookie[3] = 9;
  RequestError e;
  const auto plain = encode_request(r, "");
  ASSERT_EQ(plain.size(), IPS_SUB_REQUEST_HEADER + 8);
  auto back = decode_request(plain, "", e);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->ids, r.ids);
  EXPECT_EQ(back->format, WireFormat::kJson);
  EXPECT_EQ(back->lease_s, 45);
  EXPECT_EQ(back->cookie, r.cookie);
  EXPECT_FALSE(back->all);

  const auto keyed = encode_request(r, "secret");
  EXPECT_EQ(keyed.size(), plain.size() + IPS_SUB_MAC_SIZE);
  EXPECT_TRUE(decode_request(keyed, "secret", e));
  EXPECT_FALSE(decode_request(keyed, "other", e));
  EXPECT_EQ(e, RequestError::kBadKey);
  EXPECT_FALSE(decode_request(plain, "secret", e));
  EXPECT_EQ(e, RequestError::kBadKey);
  auto flipped = keyed;
  flipped[9] ^= 1;  // lease changed in flight
  EXPECT_FALSE(decode_request(flipped, "secret", e));
  EXPECT_EQ(e, RequestError::kBadKey);
  EXPECT_FALSE(decode_request(std::vector<std::uint8_t>(plain.begin(), plain.begin() + 20), "", e));
  EXPECT_EQ(e, RequestError::kMalformed);

  EXPECT_TRUE(parse_subnet("10.0.0.0/8"));
  EXPECT_TRUE(parse_subnet("0.0.0.0/0"));
  EXPECT_TRUE(parse_subnet("127.0.0.1")->contains(0x7F000001u));
  EXPECT_FALSE(parse_subnet("127.0.0.1")->contains(0x7F000002u));
  EXPECT_TRUE(parse_subnet("192.168.0.0/16")->contains(0xC0A8FF01u));
  EXPECT_FALSE(parse_subnet("10.0.0.1/8"));  // host bits set
  EXPECT_FALSE(parse_subnet("10.0.0.0/33"));
  EXPECT_FALSE(parse_subnet("10.0.0/8"));
  EXPECT_FALSE(parse_subnet("lab"));
}

TEST(SubscriptionSink, SubscribeReceiveRenewAndExpire) {
  const std::uint16_t port = free_port();
  OutputConfig config = subscriptions_on(port);
  config.subscriptions.max_lease_s = 2;  // leases shortened to 2 s: expiry within the test
  auto sink = make_output_sink(config, 0);
  Peer robot;

  Request r;
  r.all = false;
  r.ids = {2};
  r.lease_s = 60;
  auto accepted = subscribe(robot, port, r);
  ASSERT_TRUE(accepted);
  EXPECT_EQ(accepted->status, Status::kAccepted);
  EXPECT_EQ(accepted->lease_s, 2);  // capped by max_lease
  const std::int64_t t0 = monotonic_ns();
  auto sleep_until = [&](double s) {
    std::this_thread::sleep_until(std::chrono::steady_clock::now() +
                                  std::chrono::nanoseconds(t0 + static_cast<std::int64_t>(s * 1e9) - monotonic_ns()));
  };

  sink->publish(update_with({1, 2, 3}));
  sink->publish(update_with({1, 3}));
  auto got = robot.drain();
  ASSERT_EQ(got.size(), 2u);
  Datagram d0 = decode_datagram(got[0]), d1 = decode_datagram(got[1]);
  ASSERT_EQ(d0.markers.size(), 1u);  // only the wanted id
  EXPECT_EQ(d0.markers[0].id, 2u);
  EXPECT_EQ(d0.markers[0].x, 1.0);
  EXPECT_TRUE(d1.markers.empty());  // an update without it still arrives (the clock goes on)
  EXPECT_EQ(d1.sequence, d0.sequence + 1);

  // Renew with the cookie of the last reply: no new challenge, the lease starts again.
  r.cookie = accepted->cookie;
  sleep_until(0.7);
  robot.send(encode_request(r, ""), port);
  auto renewed = robot.reply();
  ASSERT_TRUE(renewed);
  EXPECT_EQ(renewed->status, Status::kAccepted);
  sleep_until(2.2);  // past the first lease, within the renewed one (until ~2.7 s)
  sink->publish(update_with({2}));
  EXPECT_EQ(robot.drain().size(), 1u) << "the renewal must have extended the lease";

  sleep_until(3.4);  // past the renewed lease
  sink->publish(update_with({2}));
  EXPECT_TRUE(robot.drain().empty()) << "an expired lease must stop the stream";
  const OutputStats s = sink->stats();
  EXPECT_EQ(counter(s, "subscribers"), 0u);
  EXPECT_EQ(counter(s, "expired"), 1u);
  EXPECT_EQ(counter(s, "accepted"), 2u);
  EXPECT_EQ(s.datagrams, 3u);
}

TEST(SubscriptionSink, UnverifiedAndSpoofedSourcesGetNoStream) {
  const std::uint16_t port = free_port();
  auto sink = make_output_sink(subscriptions_on(port), 0);
  // The victim: its address appears as a request's source (as a forged packet would make it),
  // but it never echoes the cookie.
  Peer victim, attacker;
  const Request r;
  const auto request = encode_request(r, "");
  victim.send(request, port);
  const auto challenge = victim.receive(2000);
  ASSERT_TRUE(challenge);
  EXPECT_LE(challenge->size(), request.size());
  // The attacker gets a cookie for its own address and replays it from the victim's address,
  // and guesses one: both are refused (challenged again), neither starts a stream.
  const auto mine = subscribe(attacker, port, r);
  ASSERT_TRUE(mine);
  Request replay = r;
  replay.cookie = mine->cookie;
  victim.send(encode_request(replay, ""), port);
  Request guess = r;
  guess.cookie.fill(0xAB);
  victim.send(encode_request(guess, ""), port);

  for (int i = 0; i < 5; ++i) sink->publish(update_with({1}));
  const auto at_victim = victim.drain();
  for (const auto& d : at_victim) {
    const auto reply = decode_reply(d);
    ASSERT_TRUE(reply) << "the victim received stream data";
    EXPECT_EQ(reply->status, Status::kChallenge);
  }
  EXPECT_EQ(at_victim.size(), 2u);         // the two re-challenges
  EXPECT_EQ(attacker.drain().size(), 5u);  // the verified attacker address itself is served
  const OutputStats s = sink->stats();
  EXPECT_EQ(counter(s, "refused_cookie"), 2u);
  EXPECT_EQ(counter(s, "subscribers"), 1u);
}

TEST(SubscriptionSink, RequestFloodIsNotAmplified) {
  const std::uint16_t port = free_port();
  auto sink = make_output_sink(subscriptions_on(port), 0);
  Peer flood;
  std::uint64_t sent = 0;
  Request r;
  Request with_ids;
  with_ids.all = false;
  with_ids.ids = {1, 2, 3};
  const std::vector<std::vector<std::uint8_t>> kinds = {
      encode_request(r, ""),         // unverified: challenged
      encode_request(with_ids, ""),  // unverified, larger
      [&] {
        Request g = r;
        g.cookie.fill(0x5A);
        return encode_request(g, "");
      }(),                                  // forged cookie
      std::vector<std::uint8_t>(40, 0x41),  // garbage
      std::vector<std::uint8_t>(1, 0x00),   // runt
  };
  for (int i = 0; i < 100000; ++i) {
    const auto& b = kinds[static_cast<std::size_t>(i) % kinds.size()];
    flood.send(b, port);
    sent += b.size();
    if (i % 5000 == 4999) sink->publish(update_with({1}));  // the stream runs meanwhile
  }
  std::uint64_t received = 0;
  std::size_t stream = 0;
  for (const auto& d : flood.drain()) {
    received += d.size();
    stream += !decode_reply(d).has_value();
  }
  EXPECT_EQ(stream, 0u) << "an unverified source received stream data";
  EXPECT_LE(received, sent);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the receive thread catches up
  const OutputStats s = sink->stats();
  const std::uint64_t in = counter(s, "unverified_bytes_in"), out = counter(s, "unverified_bytes_out");
  EXPECT_GT(in, 0u);
  EXPECT_LE(out, in) << "the daemon sent more to unverified sources than it received from them";
  EXPECT_EQ(s.datagrams, 0u);
  EXPECT_GT(counter(s, "refused_malformed"), 0u);
  EXPECT_GT(counter(s, "refused_cookie"), 0u);
  std::printf("flood: client sent %llu B, received %llu B; daemon unverified in %llu B, out %llu B, challenges %llu\n",
              static_cast<unsigned long long>(sent), static_cast<unsigned long long>(received),
              static_cast<unsigned long long>(in), static_cast<unsigned long long>(out),
              static_cast<unsigned long long>(counter(s, "challenges")));
}

TEST(SubscriptionSink, DisallowedSubnetPreSharedKeyAndSubscriberLimit) {
  const std::uint16_t port = free_port();
  OutputConfig config = subscriptions_on(port);
  config.subscriptions.allow = {"127.0.0.1/32", "127.0.1.0/24"};
  config.subscriptions.psk = "lab key";
  config.subscriptions.max_subscribers = 1;
  auto sink = make_output_sink(config, 0);
  const Request r;

  Peer outsider("127.0.0.2");  // not in allow: no answer at all
  outsider.send(encode_request(r, "lab key"), port);
  EXPECT_FALSE(outsider.receive(500));

  Peer keyless;  // allowed address, no HMAC: no answer
  keyless.send(encode_request(r, ""), port);
  keyless.send(encode_request(r, "wrong key"), port);
  EXPECT_FALSE(keyless.receive(500));

  Peer first;
  const auto ok = subscribe(first, port, r, "lab key");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, Status::kAccepted);
  Peer second("127.0.1.9");
  const auto full = subscribe(second, port, r, "lab key");
  ASSERT_TRUE(full);
  EXPECT_EQ(full->status, Status::kRefusedFull);

  sink->publish(update_with({4}));
  EXPECT_EQ(first.drain().size(), 1u);
  EXPECT_TRUE(second.drain().empty());
  EXPECT_TRUE(outsider.drain().empty());
  const OutputStats s = sink->stats();
  EXPECT_EQ(counter(s, "refused_subnet"), 1u);
  EXPECT_EQ(counter(s, "refused_key"), 2u);
  EXPECT_EQ(counter(s, "refused_full"), 1u);

  // Unsubscribing frees the place.
  Request bye = r;
  bye.op = Op::kUnsubscribe;
  bye.cookie = ok->cookie;
  first.send(encode_request(bye, "lab key"), port);
  const auto gone = first.reply();
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->status, Status::kUnsubscribed);
  const auto now_ok = subscribe(second, port, r, "lab key");
  ASSERT_TRUE(now_ok);
  EXPECT_EQ(now_ok->status, Status::kAccepted);
}

TEST(SubscriptionSink, BadAllowEntryAndBusyPortNameTheKey) {
  const std::uint16_t port = free_port();
  OutputConfig config = subscriptions_on(port);
  config.subscriptions.allow = {"10.0.0.0/8", "10.1.2.3/8"};
  try {
    (void)make_output_sink(config, 3);
    ADD_FAILURE() << "accepted a bad subnet";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("outputs[3].allow[1]"), std::string::npos) << e.what();
  }
  Peer holder;  // another program already has the port
  OutputConfig busy = subscriptions_on(ntohs(holder.self.sin_port));
  try {
    (void)make_output_sink(busy, 2);
    ADD_FAILURE() << "listened on a port in use";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("outputs[2].port: cannot listen on 127.0.0.1:"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ips
