// Range solver costs per fix (Petković et al. report ~1 ms per fix on an Atom with GSL's
// Nelder-Mead): Petković's geometry (4 devices at the corners of a 6 x 4 m rectangle at 2.5 m,
// beacon at 1.3 m known) and a free 3-D fix from 8 anchors at several heights, ranges with 5 cm
// noise (and, for robust, one range of each fix +0.5 m: the leave-one-out step's cost).
// Run: build/release/tools/bench_ranging
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "ips/ranging/multilateration.h"

namespace {

struct Case {
  std::vector<std::vector<ips::RangeToAnchor>> fixes;
  ips::RangeSolveOptions options;
};

Case make_case(bool petkovic, bool nlos = false) {
  std::vector<Eigen::Vector3d> anchors;
  if (petkovic)
    anchors = {{0, 0, 2.5}, {6, 0, 2.5}, {6, 4, 2.5}, {0, 4, 2.5}};
  else
    anchors = {{0, 0, 2.5}, {8, 0, 0.4}, {8, 6, 2.4}, {0, 6, 0.6}, {4, 0, 1.8}, {8, 3, 2.9}, {4, 6, 0.3}, {0, 3, 1.5}};
  Case c;
  if (petkovic) c.options.known_height = 1.3;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> ux(0.5, petkovic ? 5.5 : 7.5), uy(0.5, petkovic ? 3.5 : 5.5), uz(0.1, 1.5);
  std::normal_distribution<double> noise(0, 0.05);
  for (int i = 0; i < 256; ++i) {
    const Eigen::Vector3d tag(ux(rng), uy(rng), petkovic ? 1.3 : uz(rng));
    std::vector<ips::RangeToAnchor> f;
    for (const auto& a : anchors) f.push_back({a, (a - tag).norm() + noise(rng), 0.05});
    if (nlos) f[static_cast<std::size_t>(i) % f.size()].range_m += 0.5;  // one non-line-of-sight range
    c.fixes.push_back(std::move(f));
  }
  return c;
}

template <typename Solve>
void run(benchmark::State& state, bool petkovic, Solve solve, bool nlos = false) {
  const Case c = make_case(petkovic, nlos);
  std::size_t i = 0, failed = 0;
  for (auto _ : state) {
    const ips::RangeFix f = solve(c.fixes[i++ % c.fixes.size()], c.options);
    failed += !f.ok;
    benchmark::DoNotOptimize(f);
  }
  state.counters["failed"] = static_cast<double>(failed);
}

void robust(benchmark::State& s, bool p) {
  run(s, p, [](const auto& f, const auto& o) { return ips::fix_least_squares(f, o); });
}
void robust_nlos(benchmark::State& s, bool p) {
  run(
      s, p, [](const auto& f, const auto& o) { return ips::fix_least_squares(f, o); }, true);
}
void lsq(benchmark::State& s, bool p) {
  run(s, p, [](const auto& f, auto o) {
    o.robust_sigmas = 0;
    return ips::fix_least_squares(f, o);
  });
}
void nelder_mead(benchmark::State& s, bool p) {
  run(s, p, [](const auto& f, const auto& o) { return ips::fix_nelder_mead(f, o); });
}
void median4(benchmark::State& s, bool p) {
  run(s, p, [](const auto& f, const auto& o) { return ips::fix_from_subsets(f, ips::SubsetVote::kMedian, o); });
}

BENCHMARK_CAPTURE(robust, petkovic_4_at_known_height, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(lsq, petkovic_4_at_known_height, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(nelder_mead, petkovic_4_at_known_height, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(median4, petkovic_4_at_known_height, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(robust, free_3d_8_anchors, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(robust_nlos, free_3d_8_anchors_one_nlos, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(nelder_mead, free_3d_8_anchors, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(median4, free_3d_8_anchors, false)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
