// `ips sim ranges`: the ranges the scene's tags measure when they fire, as `ips trilaterate`
// reads them (ranges.csv, anchors.yaml), with the exact tag positions beside them (truth.csv);
// or, with --send, fired in real time to an ipsd range input (sim_range_sender.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include "command.h"
#include "image_io.h"
#include "ips/core/error.h"
#include "ips/sim/scene.h"
#include "sim_range_sender.h"

namespace cmd_sim_ranges {  // named, not anonymous: unique in a unity build

struct Args {
  std::string scene, out, truth, anchors, send, psk;
  double rate = 10.0, seconds = 10.0, start = 0.0;
  std::int64_t epoch = -1;
  unsigned seed = 1;
  std::vector<int> tags;
  TransportFaults faults;
};

SendPlan send_plan(const Args& a) {
  SendPlan plan;
  const auto colon = a.send.rfind(':');
  int port = 0;
  try {
    port = colon == std::string::npos ? 0 : std::stoi(a.send.substr(colon + 1));
  } catch (const std::exception&) {
    port = 0;
  }
  if (port < 1 || port > 65535)
    throw ips::InputError("--send: expected HOST:PORT (ipsd's ranging.port), got '" + a.send + "'");
  plan.host = a.send.substr(0, colon);
  plan.port = static_cast<std::uint16_t>(port);
  plan.psk = a.psk;
  plan.rate_hz = a.rate;
  plan.seconds = a.seconds;
  plan.scene_start_s = a.start;
  plan.scene_epoch_mono_ns = a.epoch;
  plan.seed = a.seed;
  plan.tags = a.tags;
  plan.faults = a.faults;
  plan.truth_csv = a.truth;
  const TransportFaults& f = a.faults;
  if (!(f.max_delay_s >= 0 && f.max_delay_s <= 10)) throw ips::InputError("--delay: must be in [0, 10] s");
  if (!(f.burst_s >= 0 && f.burst_s <= 10)) throw ips::InputError("--burst: must be in [0, 10] s");
  if (!(f.loss >= 0 && f.loss < 1)) throw ips::InputError("--loss: must be in [0, 1)");
  if (!(f.duplicate >= 0 && f.duplicate <= 1)) throw ips::InputError("--duplicate: must be in [0, 1]");
  return plan;
}

int run(const Args& a) {
  const ips::sim::Scene scene = ips::sim::Scene::load(a.scene);
  if (scene.anchors.empty() || scene.tags.empty())
    throw ips::InputError(a.scene + ": needs anchors: and tags: to range (docs/simulator.md, \"Ranges\")");
  if (!(a.rate > 0 && a.rate <= 1000)) throw ips::InputError("--rate: must be in (0, 1000] Hz");
  if (!(a.seconds > 0 && a.seconds * a.rate <= 1e6))
    throw ips::InputError("--seconds: must be > 0, at most 1e6 firings");
  std::set<int> wanted(a.tags.begin(), a.tags.end());
  for (int id : wanted)
    if (std::none_of(scene.tags.begin(), scene.tags.end(), [&](const auto& t) { return t.id == id; }))
      throw ips::InputError("--tag " + std::to_string(id) + ": not a tag of " + a.scene);
  if (a.out.empty() == a.send.empty()) throw ips::InputError("give either --out (a file) or --send (to ipsd)");
  if (!a.send.empty()) return send_ranges(scene, send_plan(a));

  std::ostringstream ranges, truth;
  ranges.precision(9);
  truth.precision(9);
  ranges << "fix,reference,range,sigma,ref_x,ref_y,ref_z,ref_sigma\n";
  truth << "fix,tag,t,x,y,z\n";
  std::mt19937_64 rng(a.seed);
  const long firings = std::lround(a.seconds * a.rate);
  std::size_t rows = 0, fixes = 0;
  for (long k = 0; k < firings; ++k) {
    const double t = static_cast<double>(k) / a.rate;
    for (std::size_t i = 0; i < scene.tags.size(); ++i) {
      if (!wanted.empty() && !wanted.count(scene.tags[i].id)) continue;
      const auto here = scene.tag_position(i, t);
      const auto measured = scene.fire_tag(i, t, rng);
      if (!here || measured.empty()) continue;
      char fix[64];
      std::snprintf(fix, sizeof fix, "tag%d_%06ld", scene.tags[i].id, k);
      truth << fix << ',' << scene.tags[i].id << ',' << t << ',' << here->x() << ',' << here->y() << ',' << here->z()
            << '\n';
      for (const auto& r : measured) {
        ranges << fix << ',' << (r.is_tag ? "tag" : "") << r.reference << ',' << r.range << ',' << r.sigma;
        // Another tag is a mobile reference: its position inline (exact here; ref_sigma 0).
        if (r.is_tag)
          ranges << ',' << r.reference_position.x() << ',' << r.reference_position.y() << ','
                 << r.reference_position.z() << ",0";
        else
          ranges << ",,,,";
        ranges << '\n';
        ++rows;
      }
      ++fixes;
    }
  }
  ips::cli::write_file_atomically(a.out, ranges.str());
  if (!a.truth.empty()) ips::cli::write_file_atomically(a.truth, truth.str());
  if (!a.anchors.empty()) {
    std::ostringstream y;
    y.precision(9);
    y << "# the anchors of " << a.scene << "\nanchors:\n";
    for (const auto& an : scene.anchors)
      y << "  - {id: " << an.id << ", x: " << an.position.x() << ", y: " << an.position.y()
        << ", z: " << an.position.z() << (an.bias != 0 ? ", bias: " + std::to_string(an.bias) : std::string()) << "}\n";
    ips::cli::write_file_atomically(a.anchors, y.str());
  }
  std::printf("wrote %zu ranges of %zu firings to %s\n", rows, fixes, a.out.c_str());
  return 0;
}

std::function<int()> setup(CLI::App& sub) {
  auto a = std::make_shared<Args>();
  sub.add_option("--scene", a->scene, "Scene YAML file with anchors: and tags:")->required();
  sub.add_option("--out", a->out, "Ranges CSV, as ips trilaterate reads it (or --send)");
  sub.add_option("--truth", a->truth, "Exact tag positions per fix: fix,tag,t,x,y,z (--send: and firing_realtime_ns)");
  sub.add_option("--anchors", a->anchors,
                 "Write the scene's anchors (positions, biases) as ips trilaterate's anchors.yaml");
  sub.add_option("--rate", a->rate, "Firings per second of every tag")->capture_default_str();
  sub.add_option("--seconds", a->seconds, "Scene time to simulate")->capture_default_str();
  sub.add_option("--seed", a->seed, "Random seed of the noise and dropouts")->capture_default_str();
  sub.add_option("--tag", a->tags, "Only these tags (repeatable; default all)");
  sub.add_option("--send", a->send,
                 "HOST:PORT: fire in real time to ipsd's range input for --seconds of wall time, instead of --out");
  sub.add_option("--psk", a->psk, "--send: the range input's pre-shared key (ranging.psk)");
  sub.add_option("--start", a->start, "--send: the scene time of the first firing (s)")->capture_default_str();
  sub.add_option("--scene-epoch", a->epoch,
                 "--send: CLOCK_MONOTONIC ns of scene time 0, to fire in step with ipsd's synthetic cameras (its "
                 "status' synthetic_epoch_mono_ns)");
  sub.add_option("--delay", a->faults.max_delay_s, "--send: hold each datagram back by up to this many seconds")
      ->capture_default_str();
  sub.add_option("--burst", a->faults.burst_s, "--send: release datagrams only at the end of slots this long (s)")
      ->capture_default_str();
  sub.add_option("--loss", a->faults.loss, "--send: probability a datagram is lost")->capture_default_str();
  sub.add_option("--duplicate", a->faults.duplicate, "--send: probability a datagram is sent twice")
      ->capture_default_str();
  sub.add_option("--unknown-anchor", a->faults.unknown_anchor, "--send: every firing also ranges to this anchor id");
  return [a] { return run(*a); };
}

IPS_REGISTER_SIM_COMMAND("ranges", "The ranges the scene's tags measure, for ips trilaterate, with the exact truth",
                         setup);

}  // namespace cmd_sim_ranges
