// `ips listen`: receive the position stream (binary or JSON, detected per datagram), print
// live positions with rate and age per marker (and per rigid body, version 2); malformed datagrams are counted and
// warned about. With --subscribe, asks a daemon's `subscriptions` output for a unicast stream to this socket (cookie
// exchange, renewals, unsubscribe at the end: include/ips/output/wire.h).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <string_view>

#include "command.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/output/packet_codec.h"
#include "ips/output/subscription.h"
#include "ips/output/wire.h"

namespace cmd_listen {  // named, not anonymous: unique in a unity build

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct ListenOptions {
  std::string bind = "0.0.0.0:5005";
  std::string group;               // multicast group:port; replaces --bind
  std::string interface;           // local IPv4 address of the interface to join the group on
  bool json = false;               // print every decoded datagram as one JSON line
  std::string record;              // also write every valid datagram as one JSON line to this file
  double interval_s = 1.0;         // table refresh period
  long count = 0;                  // stop after this many valid datagrams (0 = never)
  double duration_s = 0;           // stop after this many seconds (0 = never)
  std::string subscribe;           // daemon ADDR:PORT of a subscriptions output; "" = just listen
  std::vector<std::uint32_t> ids;  // with --subscribe: wanted marker ids (none = all)
  std::string format = "binary";   // with --subscribe: the stream's format
  int lease_s = 30;                // with --subscribe: requested lease
  std::string psk;                 // with --subscribe: the output's pre-shared key
  bool bind_given = false;
};

sockaddr_in parse_endpoint(const std::string& text, const char* option) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos)
    throw ips::InputError(std::string(option) + ": expected ADDR:PORT, got '" + text + "'");
  sockaddr_in a{};
  a.sin_family = AF_INET;
  const std::string host = text.substr(0, colon);
  if (::inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1)
    throw ips::InputError(std::string(option) + ": '" + host + "' is not an IPv4 address");
  char* end = nullptr;
  const long port = std::strtol(text.c_str() + colon + 1, &end, 10);
  if (*end != '\0' || port < 0 || port > 65535 || colon + 1 == text.size())
    throw ips::InputError(std::string(option) + ": bad port in '" + text + "'");
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  return a;
}

int open_socket(const ListenOptions& o) {
  const bool multicast = !o.group.empty();
  sockaddr_in addr = parse_endpoint(multicast ? o.group : o.bind, multicast ? "--group" : "--bind");
  if (multicast && !IN_MULTICAST(ntohl(addr.sin_addr.s_addr)))
    throw ips::InputError("--group: '" + o.group + "' is not a multicast group (224.0.0.0/4)");
  ip_mreq mreq{};
  mreq.imr_multiaddr = addr.sin_addr;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (!o.interface.empty() && ::inet_pton(AF_INET, o.interface.c_str(), &mreq.imr_interface) != 1)
    throw ips::InputError("--interface: '" + o.interface + "' is not an IPv4 address");
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  const int on = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);  // several listeners on one port
  const int rcvbuf = 1 << 20;                                  // bursts of datagrams while we print
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  sockaddr_in bind_addr = addr;
  if (multicast) bind_addr.sin_addr.s_addr = htonl(INADDR_ANY);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&bind_addr), sizeof bind_addr) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error("bind " + (multicast ? o.group : o.bind) + ": " + std::strerror(err));
  }
  if (multicast) {
    if (::setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0) {
      const int err = errno;
      ::close(fd);
      throw std::runtime_error("joining " + o.group + ": " + std::strerror(err));
    }
  }
  return fd;
}

struct MarkerView {
  ips::MarkerRecord last;
  std::int64_t capture_real_ns = 0;
  std::deque<std::int64_t> arrivals;  // monotonic ns of the last second's updates
};

struct BodyView {
  ips::BodyRecord last;
  std::int64_t capture_real_ns = 0;
  std::deque<std::int64_t> arrivals;
};

// The sources besides the overhead cameras ("ranges", "inside-out"): "+name" beside cameras,
// the name alone where no camera placed it.
void print_other_sources(std::uint16_t sources, std::uint32_t camera_mask) {
  for (const char* name : ips::wire_source_names(sources))
    if (std::string_view(name) != "camera") std::printf(camera_mask ? " +%s" : " %s", name);
}

void print_rate_age(std::deque<std::int64_t>& arrivals, std::int64_t capture_real_ns, std::int64_t now,
                    std::int64_t real) {
  while (!arrivals.empty() && now - arrivals.front() > 1'000'000'000) arrivals.pop_front();
  std::printf("  %5.1f Hz  age %7.1f ms", static_cast<double>(arrivals.size()),
              1e-6 * static_cast<double>(real - capture_real_ns));
}

int run_listen(ListenOptions o) {
  std::optional<ips::subscription::Client> client;
  sockaddr_in daemon{};
  if (!o.subscribe.empty()) {
    daemon = parse_endpoint(o.subscribe, "--subscribe");
    if (!o.group.empty()) throw ips::InputError("--subscribe: cannot be combined with --group");
    if (!o.bind_given) o.bind = "0.0.0.0:0";  // any free port: the daemon streams to where we asked from
    ips::subscription::Request r;
    r.format = ips::parse_wire_format(o.format, "--format");
    r.all = o.ids.empty();
    r.ids = o.ids;
    if (o.ids.size() > IPS_SUB_MAX_IDS)
      throw ips::InputError("--ids: at most " + std::to_string(IPS_SUB_MAX_IDS) + " ids");
    if (o.lease_s < 1 || o.lease_s > 65535) throw ips::InputError("--lease: must be 1..65535 s");
    r.lease_s = static_cast<std::uint16_t>(o.lease_s);
    client.emplace(r, o.psk);
  }
  const int fd = open_socket(o);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::fprintf(stderr, "ips listen: %s %s (Ctrl-C to stop)\n",
               client ? "subscribing at" : (o.group.empty() ? "listening on" : "joined"),
               (client            ? o.subscribe
                : o.group.empty() ? o.bind
                                  : o.group)
                   .c_str());
  auto send_to_daemon = [&](const std::vector<std::uint8_t>& b) {
    ::sendto(fd, b.data(), b.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&daemon), sizeof daemon);
  };
  auto last_state = ips::subscription::Client::State::kWaiting;

  std::uint64_t valid = 0, malformed = 0, lost = 0;
  bool have_seq = false;
  std::uint32_t last_seq = 0;
  std::map<std::uint32_t, MarkerView> markers;
  std::map<std::string, BodyView> bodies;  // version 2 streams (docs/bodies.md)
  const std::int64_t start = ips::monotonic_ns();
  std::int64_t next_print = start + static_cast<std::int64_t>(o.interval_s * 1e9);
  std::vector<std::uint8_t> buf(65536);
  // --record: what `ips score --stream` reads; binary datagrams are written in their JSON form,
  // which carries the same fields, so a recording does not depend on the output's format.
  std::ofstream record;
  if (!o.record.empty()) {
    record.open(o.record, std::ios::trunc);
    if (!record) throw ips::InputError("--record: cannot write " + o.record);
  }

  while (!g_stop) {
    const std::int64_t now = ips::monotonic_ns();
    if (o.duration_s > 0 && now - start >= static_cast<std::int64_t>(o.duration_s * 1e9)) break;
    if (o.count > 0 && valid >= static_cast<std::uint64_t>(o.count)) break;
    if (!o.json && now >= next_print) {
      next_print = now + static_cast<std::int64_t>(o.interval_s * 1e9);
      const std::int64_t real = ips::realtime_ns();
      std::printf("--- %zu marker(s), %zu bod%s, %llu datagrams, %llu malformed, %llu lost\n", markers.size(),
                  bodies.size(), bodies.size() == 1 ? "y" : "ies", static_cast<unsigned long long>(valid),
                  static_cast<unsigned long long>(malformed), static_cast<unsigned long long>(lost));
      for (auto& [id, v] : markers) {
        std::printf("id %4u  x %8.3f  y %8.3f  z %7.3f m  yaw %7.1f deg  cams 0x%02x", id, v.last.x, v.last.y, v.last.z,
                    v.last.yaw * 180.0 / std::numbers::pi, v.last.camera_mask);
        // What placed it, where the stream says (IPS_WIRE_FLAG_SOURCES: ipsd with ranging or a
        // camera on a robot).
        print_other_sources(v.last.sources, v.last.camera_mask);
        if (!v.last.has_yaw) std::printf(" (yaw held)");
        print_rate_age(v.arrivals, v.capture_real_ns, now, real);
        if (v.last.vx != 0 || v.last.vy != 0) std::printf("  v (%.2f, %.2f) m/s", v.last.vx, v.last.vy);
        std::printf("\n");
      }
      for (auto& [name, v] : bodies) {
        const auto& b = v.last;
        std::printf("body %-12s  x %8.3f  y %8.3f  z %7.3f m  yaw ", name.c_str(), b.x, b.y, b.z);
        const bool held = !b.has_yaw && (b.sources & IPS_WIRE_SOURCE_RANGES);
        if (b.has_yaw || held)
          std::printf("%7.1f deg", b.yaw * 180.0 / std::numbers::pi);
        else
          std::printf("      - deg");
        std::printf("  q (%.3f %.3f %.3f %.3f)  cams 0x%02x", b.qw, b.qx, b.qy, b.qz, b.camera_mask);
        print_other_sources(b.sources, b.camera_mask);
        if (held) std::printf(" (yaw held)");
        std::printf("  ids");
        for (const auto id : b.ids) std::printf(" %u", id);
        if (b.id_count > b.ids.size()) std::printf(" +%zu", b.id_count - b.ids.size());
        print_rate_age(v.arrivals, v.capture_real_ns, now, real);
        if (b.has_velocity) std::printf("  v (%.2f, %.2f) m/s", b.vx, b.vy);
        if (b.has_yaw_rate) std::printf("  yaw rate %.1f deg/s", b.yaw_rate * 180.0 / std::numbers::pi);
        std::printf("\n");
      }
      std::fflush(stdout);
    }
    if (client)
      if (auto request = client->due(now)) send_to_daemon(*request);
    pollfd p{fd, POLLIN, 0};
    const int timeout_ms = 50;
    const int rc = ::poll(&p, 1, timeout_ms);
    if (rc < 0 && errno == EINTR) continue;
    if (rc <= 0) continue;
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n < 0) continue;
    if (client && client->on_datagram(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)),
                                      ips::monotonic_ns())) {
      if (client->state() != last_state) {
        last_state = client->state();
        if (last_state == ips::subscription::Client::State::kSubscribed)
          std::fprintf(stderr, "ips listen: subscribed at %s (lease %u s, renewed every third)\n", o.subscribe.c_str(),
                       client->lease_s());
        else if (last_state == ips::subscription::Client::State::kRefusedFull)
          std::fprintf(stderr, "ips listen: warning: %s is full (max_subscribers); retrying every 5 s\n",
                       o.subscribe.c_str());
      }
      continue;
    }
    ips::Datagram d;
    try {
      d = ips::decode_datagram(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)));
    } catch (const ips::InputError& e) {
      ++malformed;
      // The first few in full, then one line per 1000 so a flood cannot drown the terminal.
      if (malformed <= 5 || malformed % 1000 == 0)
        std::fprintf(stderr, "ips listen: warning: %s (%llu malformed so far)\n", e.what(),
                     static_cast<unsigned long long>(malformed));
      continue;
    }
    ++valid;
    if (have_seq && d.sequence != last_seq + 1) {
      const std::uint32_t gap = d.sequence - last_seq - 1;
      if (gap < 1'000'000) lost += gap;  // else: the daemon restarted
    }
    have_seq = true;
    last_seq = d.sequence;
    if (o.json || record.is_open()) {
      std::string line = ips::encode_json(d);
      if (line.empty() || line.back() != '\n') line += '\n';
      if (o.json) {
        std::fputs(line.c_str(), stdout);
        std::fflush(stdout);
      }
      if (record.is_open()) record << line << std::flush;
    }
    const std::int64_t arrived = ips::monotonic_ns();
    for (const auto& m : d.markers) {
      MarkerView& v = markers[m.id];
      v.last = m;
      v.capture_real_ns = d.capture_realtime_ns + static_cast<std::int64_t>(m.dt_us) * 1000;
      v.arrivals.push_back(arrived);
    }
    for (const auto& b : d.bodies) {
      BodyView& v = bodies[b.name];
      v.last = b;
      v.capture_real_ns = d.capture_realtime_ns + static_cast<std::int64_t>(b.dt_us) * 1000;
      v.arrivals.push_back(arrived);
    }
  }
  if (client && client->state() == ips::subscription::Client::State::kSubscribed) send_to_daemon(client->unsubscribe());
  ::close(fd);
  std::fprintf(stderr, "ips listen: %llu datagrams, %llu malformed, %llu lost\n",
               static_cast<unsigned long long>(valid), static_cast<unsigned long long>(malformed),
               static_cast<unsigned long long>(lost));
  return 0;
}

IPS_REGISTER_COMMAND(
    "listen", "Receive and print the ipsd position stream (binary or JSON)", [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<ListenOptions>();
      auto* bind = sub.add_option("--bind", o->bind,
                                  "ADDR:PORT to receive unicast/broadcast on (with --subscribe: default any free port)")
                       ->capture_default_str();
      sub.add_option("--group", o->group, "multicast GROUP:PORT to join instead of --bind")->excludes(bind);
      sub.add_option("--interface", o->interface, "with --group: IPv4 address of the interface to join on");
      sub.add_flag("--json", o->json, "print every datagram as one JSON line (the stream's JSON form)");
      sub.add_option("--record", o->record,
                     "also write every valid datagram to FILE, one JSON line each (for ips score --stream)");
      sub.add_option("--interval", o->interval_s, "seconds between table refreshes")
          ->capture_default_str()
          ->check(CLI::PositiveNumber);
      sub.add_option("--count", o->count, "stop after N valid datagrams (0 = never)")->check(CLI::NonNegativeNumber);
      sub.add_option("--duration", o->duration_s, "stop after S seconds (0 = never)")->check(CLI::NonNegativeNumber);
      sub.add_option("--subscribe", o->subscribe,
                     "ADDR:PORT of a daemon's subscriptions output: ask it for a unicast stream");
      sub.add_option("--ids", o->ids, "with --subscribe: marker ids wanted (default all)")->delimiter(',');
      sub.add_option("--format", o->format, "with --subscribe: binary | json")->capture_default_str();
      sub.add_option("--lease", o->lease_s, "with --subscribe: lease to ask for, seconds (renewed at a third)")
          ->capture_default_str();
      sub.add_option("--psk", o->psk, "with --subscribe: the output's pre-shared key");
      return [=] {
        o->bind_given = bind->count() > 0;
        return run_listen(*o);
      };
    });

}  // namespace cmd_listen
