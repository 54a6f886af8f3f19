// What publish() costs the fusion thread for the mavlink and subscriptions outputs: time per
// update (10 markers) on loopback, median / p99 / max over N updates. The subscribers never
// read: their receive buffers overflow and the kernel drops what does not fit, which costs the
// sender nothing (sendto is MSG_DONTWAIT anyway). Usage: bench_outputs [updates=3000] [subscribers=16]
#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "ips/core/clock.h"
#include "ips/output/output_sink.h"
#include "ips/output/subscription.h"
#include "loopback_udp.h"

namespace {

ips::Datagram update(int k) {
  ips::Datagram d;
  d.has_velocity = true;
  d.capture_monotonic_ns = ips::monotonic_ns();
  d.capture_realtime_ns = ips::realtime_ns();
  d.update = static_cast<std::uint32_t>(k);
  for (std::uint32_t id = 1; id <= 10; ++id) {
    ips::MarkerRecord m;
    m.id = id;
    m.x = 0.1 * id + 1e-3 * k;
    m.y = 0.2 * id;
    m.z = 0.15;
    m.covariance = {1e-4, 0, 0, 1e-4, 0, 1e-4};
    d.markers.push_back(m);
  }
  return d;
}

void report(const char* name, std::vector<double> us, const ips::OutputStats& s) {
  std::sort(us.begin(), us.end());
  std::printf("%-44s publish() per update: median %.1f us, p99 %.1f us, max %.1f us; sent %llu, send errors %llu\n",
              name, us[us.size() / 2], us[us.size() * 99 / 100], us.back(),
              static_cast<unsigned long long>(s.datagrams), static_cast<unsigned long long>(s.send_errors));
}

// A subscriber that completes the cookie exchange and then never reads its socket.
int subscribe(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in self{};
  self.sin_family = AF_INET;
  self.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&self), sizeof self);
  sockaddr_in to = self;
  to.sin_port = htons(port);
  ips::subscription::Client client(ips::subscription::Request{}, "");
  std::vector<std::uint8_t> buf(2048);
  for (int i = 0; i < 50 && client.state() != ips::subscription::Client::State::kSubscribed; ++i) {
    if (auto b = client.due(ips::monotonic_ns()))
      ::sendto(fd, b->data(), b->size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) == 1) {
      const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
      if (n > 0)
        client.on_datagram(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)), ips::monotonic_ns());
    }
  }
  if (client.state() != ips::subscription::Client::State::kSubscribed) std::fprintf(stderr, "subscribe failed\n");
  return fd;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 3000;
  const int subscribers = argc > 2 ? std::atoi(argv[2]) : 16;

  ips::support::UdpReceiver mav_rx;
  ips::OutputConfig mav;
  mav.kind = ips::OutputConfig::Kind::kMavlink;
  mav.address = "127.0.0.1";
  mav.port = mav_rx.port;
  mav.mavlink.odometry = true;
  mav.mavlink.rate_limit_hz = 1e6;  // every update: measure the packing, not the limiter
  for (int v = 1; v <= 4; ++v) mav.mavlink.vehicles.push_back({v, v, "", 0, 0.0});
  auto mav_sink = ips::make_output_sink(mav, 0);
  std::vector<double> us;
  for (int k = 0; k < n; ++k) {
    const ips::Datagram d = update(k);
    const std::int64_t t0 = ips::monotonic_ns();
    mav_sink->publish(d);
    us.push_back(1e-3 * static_cast<double>(ips::monotonic_ns() - t0));
  }
  report("mavlink, 4 vehicles, VPE + ODOMETRY:", us, mav_sink->stats());

  ips::OutputConfig sub;
  sub.kind = ips::OutputConfig::Kind::kSubscriptions;
  sub.address = "127.0.0.1";
  sub.port = [] {
    ips::support::UdpReceiver r;
    return r.port;
  }();
  sub.subscriptions.max_subscribers = std::max(1, subscribers);
  auto sub_sink = ips::make_output_sink(sub, 1);
  std::vector<int> fds;
  for (int i = 0; i < subscribers; ++i) fds.push_back(subscribe(sub.port));
  us.clear();
  for (int k = 0; k < n; ++k) {
    const ips::Datagram d = update(k);
    const std::int64_t t0 = ips::monotonic_ns();
    sub_sink->publish(d);
    us.push_back(1e-3 * static_cast<double>(ips::monotonic_ns() - t0));
  }
  char name[64];
  std::snprintf(name, sizeof name, "subscriptions, %d subscribers (never reading):", subscribers);
  report(name, us, sub_sink->stats());
  for (int fd : fds) ::close(fd);
  return 0;
}
