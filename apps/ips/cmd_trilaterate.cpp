// `ips trilaterate`: positions from ranges to anchors, offline (docs/ranging.md). One fix per
// `fix` value of the ranges file, by the chosen solver; a fix that cannot be solved gets a row
// with its status word (coplanar, too_few, ...) and no position.
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "command.h"
#include "ips/core/error.h"
#include "ips/ranging/multilateration.h"
#include "ips/ranging/ranges_file.h"
#include "ips/ranging/speed_of_sound.h"

namespace cmd_trilaterate {  // named, not anonymous: unique in a unity build

struct Options {
  std::string anchors, ranges, out, method = "robust";
  std::optional<double> height;
  std::vector<double> z_range;
  std::optional<double> temperature;  // ultrasound: the air's, degC
  double assumed_speed = 343.0;       // the speed of sound the ranges were computed with, m/s
  bool json = false;
};

ips::RangeFix solve(const Options& o, const ips::RangeFixInput& fix) {
  ips::RangeSolveOptions options;
  options.known_height = o.height;
  if (o.z_range.size() == 2) options.z_range = std::make_pair(o.z_range[0], o.z_range[1]);
  return ips::fix_by_method(o.method, fix.ranges, options, "--method");
}

int run(const Options& o) {
  if (o.z_range.size() == 2 && !(o.z_range[0] <= o.z_range[1]))
    throw ips::InputError("--z-range: the minimum is above the maximum");
  std::map<std::string, double> biases;
  const ips::AnchorMap anchors = ips::load_anchors_yaml(o.anchors, &biases);
  std::ifstream in(o.ranges);
  if (!in) throw ips::InputError(o.ranges + ": cannot read the file");
  auto inputs = ips::parse_ranges_csv(in, o.ranges, anchors);
  if (o.temperature) {  // ultrasound: every range scaled to the air's speed of sound
    const double air = ips::ultrasound_range_scale(*o.temperature, o.assumed_speed);
    for (auto& input : inputs)
      for (auto& r : input.ranges) r.range_m *= air;
  }
  for (auto& input : inputs)  // each anchor's bias (ips ranging calibrate) undone, as ipsd does
    for (std::size_t i = 0; i < input.ranges.size(); ++i)
      if (!input.anchors[i].empty()) input.ranges[i].range_m -= biases[input.anchors[i]];
  std::vector<ips::NamedFix> fixes;
  int solved = 0;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    fixes.push_back({inputs[i].fix, solve(o, inputs[i])});
    if (fixes.back().result.ok) ++solved;
    if (inputs.size() >= 1000 && (i + 1) % 1000 == 0)
      std::fprintf(stderr, "\rips trilaterate: %zu / %zu fixes", i + 1, inputs.size());
  }
  if (inputs.size() >= 1000) std::fprintf(stderr, "\n");
  std::ofstream out(o.out);
  if (!out) throw ips::InputError(o.out + ": cannot write the file");
  if (o.json) {
    ips::write_fixes_json(out, fixes);
  } else {
    ips::write_fixes_csv(out, fixes);
  }
  out.close();
  if (!out) throw std::runtime_error(o.out + ": writing failed");
  std::printf("%d of %zu fixes solved (%s, %zu anchors) -> %s\n", solved, fixes.size(), o.method.c_str(),
              anchors.size(), o.out.c_str());
  for (const auto& f : fixes)
    if (!f.result.ok) {
      std::printf("first unsolved: fix '%s': %s\n", f.fix.c_str(), f.result.why.c_str());
      break;
    }
  return 0;
}

IPS_REGISTER_COMMAND(
    "trilaterate", "Positions from ranges to anchors (UWB / ultrasound), offline, one per fix",
    [](CLI::App& sub) -> std::function<int()> {
      auto o = std::make_shared<Options>();
      sub.add_option("--anchors", o->anchors, "anchors.yaml: anchors: [{id, x, y, z[, bias]}]")
          ->required()
          ->check(CLI::ExistingFile);
      sub.add_option("--ranges", o->ranges, "ranges.csv: fix,reference,range[,sigma,ref_x,ref_y,ref_z,ref_sigma]")
          ->required()
          ->check(CLI::ExistingFile);
      sub.add_option("--out", o->out, "fixes.csv: fix,x,y,z,cxx,cxy,cxz,cyy,cyz,czz,n,status")->required();
      sub.add_option(
             "--method", o->method,
             "robust (Cauchy least squares, contradicted ranges left out) | lsq | median4 | mean4 (Albayati & Kurt) | "
             "nelder-mead (Petkovic et al.)")
          ->check(CLI::IsMember(ips::range_method_names()))
          ->capture_default_str();
      auto* height = sub.add_option("--height", o->height, "the tags' known height (m): 2-D fixes");
      sub.add_option("--z-range", o->z_range, "ZMIN ZMAX: the heights a tag can be at (m)")
          ->expected(2)
          ->excludes(height);
      sub.add_option("--temperature", o->temperature,
                     "ultrasound: the air's temperature (degC); ranges are scaled by c(T) / --assumed-speed")
          ->check(CLI::Range(-40.0, 60.0));
      sub.add_option("--assumed-speed", o->assumed_speed,
                     "ultrasound: the speed of sound the ranges were computed with (m/s)")
          ->check(CLI::Range(300.0, 400.0))
          ->capture_default_str();
      sub.add_flag("--json", o->json, "write the fixes as JSON instead of CSV");
      return [o] { return run(*o); };
    });

}  // namespace cmd_trilaterate
