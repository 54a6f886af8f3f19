// `ips sim ranges`: the ranges the scene's tags measure when they fire, as `ips trilaterate`
// reads them (ranges.csv, anchors.yaml), with the exact tag positions beside them (truth.csv).
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

namespace cmd_sim_ranges {  // named, not anonymous: unique in a unity build

struct Args {
  std::string scene, out, truth, anchors;
  double rate = 10.0, seconds = 10.0;
  unsigned seed = 1;
  std::vector<int> tags;
};

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
        << ", z: " << an.position.z() << "}\n";
    ips::cli::write_file_atomically(a.anchors, y.str());
  }
  std::printf("wrote %zu ranges of %zu firings to %s\n", rows, fixes, a.out.c_str());
  return 0;
}

std::function<int()> setup(CLI::App& sub) {
  auto a = std::make_shared<Args>();
  sub.add_option("--scene", a->scene, "Scene YAML file with anchors: and tags:")->required();
  sub.add_option("--out", a->out, "Ranges CSV, as ips trilaterate reads it")->required();
  sub.add_option("--truth", a->truth, "Exact tag positions per fix: fix,tag,t,x,y,z");
  sub.add_option("--anchors", a->anchors, "Write the scene's anchors as ips trilaterate's anchors.yaml");
  sub.add_option("--rate", a->rate, "Firings per second of every tag")->capture_default_str();
  sub.add_option("--seconds", a->seconds, "Scene time to simulate")->capture_default_str();
  sub.add_option("--seed", a->seed, "Random seed of the noise and dropouts")->capture_default_str();
  sub.add_option("--tag", a->tags, "Only these tags (repeatable; default all)");
  return [a] { return run(*a); };
}

IPS_REGISTER_SIM_COMMAND("ranges", "The ranges the scene's tags measure, for ips trilaterate, with the exact truth",
                         setup);

}  // namespace cmd_sim_ranges
