// Mapper costs on the published train40 (red camera): predict() is on the daemon's hot path
// (once per marker per frame), fit() runs offline in `ips fit`.
// Run: build/release/tools/bench_mapping  (or with --benchmark_filter=predict)
#include <benchmark/benchmark.h>

#include <string>

#include "ips/mapping/calib_data.h"
#include "ips/mapping/mapper.h"

namespace {

const ips::CalibSet& red() {
  static const ips::CalibData data =
      ips::load_calib_csv(std::string(IPS_SOURCE_DIR) + "/calib_data/ou2023/train40.csv");
  return *data.find("red");
}

void predict(benchmark::State& state, const std::string& method) {
  const auto& set = red();
  auto mapper = ips::make_mapper(method);
  mapper->fit(set.cam, set.world, {});
  std::size_t i = 0;
  for (auto _ : state) {
    const auto p = mapper->predict(set.cam[i % set.cam.size()], set.world[i % set.cam.size()].z());
    benchmark::DoNotOptimize(p);
    ++i;
  }
}

void fit(benchmark::State& state, const std::string& method) {
  const auto& set = red();
  for (auto _ : state) {
    auto mapper = ips::make_mapper(method);
    mapper->fit(set.cam, set.world, {});
    benchmark::DoNotOptimize(mapper);
  }
}

const int registered = [] {
  for (const auto& method : ips::mapper_names()) {
    if (method != "auto") benchmark::RegisterBenchmark(("predict/" + method).c_str(), predict, method);
    benchmark::RegisterBenchmark(("fit/" + method).c_str(), fit, method)->Unit(benchmark::kMillisecond);
  }
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
