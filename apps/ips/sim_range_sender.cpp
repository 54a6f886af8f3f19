#include "sim_range_sender.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include "image_io.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/input/range_datagram.h"

namespace cmd_sim_ranges {
namespace {

struct Queued {
  std::int64_t due_mono_ns;
  std::vector<std::uint8_t> bytes;
};

void sleep_until_mono(std::int64_t t_ns) {
  const std::int64_t wait = t_ns - ips::monotonic_ns();
  if (wait > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(wait));
}

}  // namespace

int send_ranges(const ips::sim::Scene& scene, const SendPlan& plan) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(plan.port);
  if (::inet_pton(AF_INET, plan.host.c_str(), &to.sin_addr) != 1)
    throw ips::InputError("--send: '" + plan.host + "' is not an IPv4 address");
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw ips::InputError("--send: cannot open a UDP socket");
  std::mt19937_64 rng(plan.seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::ostringstream truth;
  truth.precision(9);
  truth << "fix,tag,t,x,y,z,firing_realtime_ns\n";

  const auto period_ns = static_cast<std::int64_t>(std::llround(1e9 / plan.rate_hz));
  const auto burst_ns = static_cast<std::int64_t>(std::llround(plan.faults.burst_s * 1e9));
  const std::int64_t start = ips::monotonic_ns();
  const std::int64_t end = start + static_cast<std::int64_t>(std::llround(plan.seconds * 1e9));
  std::vector<Queued> queue;  // by due time
  std::vector<std::uint32_t> counters(scene.tags.size(), 0);
  std::vector<std::optional<double>> last_fired(scene.tags.size());  // scene time of each tag's previous firing
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uint64_t firings = 0, sent = 0, lost = 0, duplicated = 0, send_errors = 0;
  std::int64_t next_progress = start + 5'000'000'000;
  const auto flush = [&](std::int64_t now) {
    std::size_t n = 0;
    for (; n < queue.size() && queue[n].due_mono_ns <= now; ++n) {
      if (::sendto(fd, queue[n].bytes.data(), queue[n].bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to),
                   sizeof to) < 0)
        ++send_errors;
      else
        ++sent;
    }
    queue.erase(queue.begin(), queue.begin() + static_cast<std::ptrdiff_t>(n));
  };
  for (std::int64_t k = 0;; ++k) {
    const std::int64_t fire_mono = start + k * period_ns;
    // Datagrams due before this firing go first (delays and bursts make them out of order).
    while (!queue.empty() && queue.front().due_mono_ns < std::min(fire_mono, end)) {
      sleep_until_mono(queue.front().due_mono_ns);
      flush(ips::monotonic_ns());
    }
    if (fire_mono >= end) break;
    sleep_until_mono(fire_mono);
    const std::int64_t fire_real = ips::realtime_ns();
    const double t = plan.scene_epoch_mono_ns >= 0 ? 1e-9 * static_cast<double>(fire_mono - plan.scene_epoch_mono_ns)
                                                   : plan.scene_start_s + 1e-9 * static_cast<double>(fire_mono - start);
    for (std::size_t i = 0; i < scene.tags.size(); ++i) {
      const ips::sim::SceneTag& tag = scene.tags[i];
      if (!plan.tags.empty() && std::find(plan.tags.begin(), plan.tags.end(), tag.id) == plan.tags.end()) continue;
      const auto here = scene.tag_position(i, t);
      const auto measured = scene.fire_tag(i, t, rng);
      if (!here || measured.empty()) continue;
      ips::RangeFiring f;
      f.tag = static_cast<std::uint32_t>(tag.id);
      f.firing = ++counters[i];
      f.firing_realtime_ns = fire_real;
      for (const auto& r : measured)
        f.entries.push_back({static_cast<std::uint32_t>(r.reference), r.is_tag, r.range, r.sigma});
      if (tag.odometry && last_fired[i]) {  // wheels: the distance since this tag's previous firing
        const double travelled = scene.tag_travelled(i, *last_fired[i], t);
        f.odometry_m = std::max(0.0, travelled + *tag.odometry * normal(rng));
        f.odometry_sigma_m = *tag.odometry;
      }
      last_fired[i] = t;
      if (plan.faults.unknown_anchor >= 0)
        f.entries.push_back({static_cast<std::uint32_t>(plan.faults.unknown_anchor), false, 2.0, 0.0});
      truth << "tag" << tag.id << '_' << f.firing << ',' << tag.id << ',' << t << ',' << here->x() << ',' << here->y()
            << ',' << here->z() << ',' << fire_real << '\n';
      ++firings;
      const auto bytes = ips::encode_range_firing(f, plan.psk);
      if (u01(rng) < plan.faults.loss) {
        ++lost;
        continue;
      }
      std::int64_t due = fire_mono + static_cast<std::int64_t>(plan.faults.max_delay_s * 1e9 * u01(rng));
      if (burst_ns > 0) due = ((due - start) / burst_ns + 1) * burst_ns + start;  // the slot's end
      const int copies = u01(rng) < plan.faults.duplicate ? 2 : 1;
      duplicated += static_cast<std::uint64_t>(copies - 1);
      for (int c = 0; c < copies; ++c) {
        const auto at = std::upper_bound(queue.begin(), queue.end(), due,
                                         [](std::int64_t d, const Queued& q) { return d < q.due_mono_ns; });
        queue.insert(at, Queued{due, bytes});
      }
    }
    flush(ips::monotonic_ns());
    if (ips::monotonic_ns() >= next_progress) {
      std::printf("%.0f s: %llu firings, %llu datagrams sent, %llu lost, %llu duplicated\n",
                  1e-9 * static_cast<double>(ips::monotonic_ns() - start), static_cast<unsigned long long>(firings),
                  static_cast<unsigned long long>(sent), static_cast<unsigned long long>(lost),
                  static_cast<unsigned long long>(duplicated));
      std::fflush(stdout);
      next_progress += 5'000'000'000;
    }
  }
  flush(INT64_MAX);  // what is still held back goes out now
  ::close(fd);
  if (!plan.truth_csv.empty()) ips::cli::write_file_atomically(plan.truth_csv, truth.str());
  std::printf("sent %llu firings to %s:%u as %llu datagrams (%llu lost, %llu duplicated, %llu send errors)\n",
              static_cast<unsigned long long>(firings), plan.host.c_str(), plan.port,
              static_cast<unsigned long long>(sent), static_cast<unsigned long long>(lost),
              static_cast<unsigned long long>(duplicated), static_cast<unsigned long long>(send_errors));
  return send_errors == 0 ? 0 : 1;
}

}  // namespace cmd_sim_ranges
