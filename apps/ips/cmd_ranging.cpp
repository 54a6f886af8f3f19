// `ips ranging calibrate`: each anchor's position and range bias from ranges measured where the
// tag's position was known another way (the cameras, motion capture), offline
// (docs/ranging.md, "Calibrating the anchors"). Writes the anchors file back, calibrated, in
// the form both `ips trilaterate` and ipsd's `ranging.anchors` take.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.h"
#include "image_io.h"
#include "ips/core/error.h"
#include "ips/ranging/anchor_calibration.h"
#include "ips/ranging/ranges_file.h"

namespace cmd_ranging {  // named, not anonymous: unique in a unity build

struct CalibrateOptions {
  std::string anchors, ranges, positions, out;
  bool bias_only = false;
  double position_sigma = 0.005;  // m, for positions.csv rows without a sigma
  double robust_sigmas = 3.0;
  bool json = false;
};

struct AnchorResult {
  std::string id;
  Eigen::Vector3d configured;
  ips::AnchorCalibration calibration;
};

std::string yaml_of(const std::vector<AnchorResult>& results, const CalibrateOptions& o) {
  std::string text =
      "# ips ranging calibrate --ranges " + o.ranges + " --positions " + o.positions +
      "\n# an anchor not calibrated keeps its configured position and bias 0 (see its comment)\nanchors:\n";
  char line[320];
  for (const AnchorResult& r : results) {
    const bool ok = r.calibration.status == ips::AnchorCalibration::Status::kOk;
    const Eigen::Vector3d& p = ok ? r.calibration.position : r.configured;
    std::snprintf(line, sizeof line, "  - {id: %s, x: %.4f, y: %.4f, z: %.4f, bias: %.4f}", r.id.c_str(), p.x(), p.y(),
                  p.z(), ok ? r.calibration.bias_m : 0.0);
    text += line;
    if (!ok)
      text += std::string("  # not calibrated: ") + ips::anchor_calibration_status_word(r.calibration.status);
    else if (r.calibration.unknowns != ips::AnchorUnknowns::kPosition)
      text += std::string("  # estimated: ") + ips::anchor_unknowns_word(r.calibration.unknowns) +
              ", the rest as configured";
    text += "\n";
  }
  return text;
}

nlohmann::json json_of(const std::vector<AnchorResult>& results) {
  nlohmann::json all = nlohmann::json::array();
  for (const AnchorResult& r : results) {
    const ips::AnchorCalibration& c = r.calibration;
    all.push_back({{"id", r.id},
                   {"status", ips::anchor_calibration_status_word(c.status)},
                   {"estimated", ips::anchor_unknowns_word(c.unknowns)},
                   {"configured", {r.configured.x(), r.configured.y(), r.configured.z()}},
                   {"position", {c.position.x(), c.position.y(), c.position.z()}},
                   {"bias", c.bias_m},
                   {"sigma", {c.sigma(0), c.sigma(1), c.sigma(2), c.sigma(3)}},
                   {"rms", c.rms_m},
                   {"samples", c.samples},
                   {"outliers", c.outliers}});
  }
  return all;
}

int run_calibrate(const CalibrateOptions& o) {
  const ips::AnchorMap anchors = ips::load_anchors_yaml(o.anchors);
  std::ifstream ranges_in(o.ranges);
  if (!ranges_in) throw ips::InputError(o.ranges + ": cannot read the file");
  const auto fixes = ips::parse_ranges_csv(ranges_in, o.ranges, anchors);
  std::ifstream positions_in(o.positions);
  if (!positions_in) throw ips::InputError(o.positions + ": cannot read the file");
  const auto positions = ips::parse_positions_csv(positions_in, o.positions);

  // Every range to a configured anchor from a fix whose position is known is one sample.
  std::map<std::string, std::vector<ips::AnchorSample>> samples;
  std::size_t placed = 0, unplaced = 0;
  for (const auto& fix : fixes) {
    const auto at = positions.find(fix.fix);
    if (at == positions.end()) {
      ++unplaced;
      continue;
    }
    ++placed;
    const double position_sigma = at->second.sigma_m.value_or(o.position_sigma);
    for (std::size_t i = 0; i < fix.ranges.size(); ++i)
      if (!fix.anchors[i].empty())
        samples[fix.anchors[i]].push_back(
            {at->second.position, fix.ranges[i].range_m, std::hypot(fix.ranges[i].sigma_m, position_sigma)});
  }
  if (placed == 0)
    throw ips::InputError(o.positions + ": no fix of " + o.ranges + " has a position here (the 'fix' columns differ)");

  ips::AnchorCalibrationOptions options;
  if (o.bias_only) options.unknowns = ips::AnchorUnknowns::kBias;
  options.robust_sigmas = o.robust_sigmas;
  std::vector<AnchorResult> results;
  int calibrated = 0;
  for (const auto& [id, configured] : anchors) {
    const auto s = samples.find(id);
    AnchorResult r{id, configured, {}};
    r.calibration = ips::calibrate_anchor_best(
        configured, s == samples.end() ? std::vector<ips::AnchorSample>{} : s->second, options);
    if (r.calibration.status == ips::AnchorCalibration::Status::kOk) ++calibrated;
    results.push_back(r);
  }
  ips::cli::write_file_atomically(o.out, yaml_of(results, o));

  if (o.json) {
    std::printf("%s\n", json_of(results).dump(2).c_str());
  } else {
    std::printf("%zu fixes with a known position (%zu without, not used)\n", placed, unplaced);
    std::printf(
        "anchor      samples outliers | moved (cm): dx     dy     dz  (1-sigma)        | bias (cm)    | rms (cm) | "
        "estimated\n");
    for (const AnchorResult& r : results) {
      const ips::AnchorCalibration& c = r.calibration;
      const Eigen::Vector3d d = 100.0 * (c.position - r.configured);
      std::printf("%-10s %8zu %8zu | %6.1f %6.1f %6.1f (%4.1f %4.1f %4.1f) | %+5.1f +- %3.1f | %8.2f | %s\n",
                  r.id.c_str(), c.samples, c.outliers, d.x(), d.y(), d.z(), 100 * c.sigma(0), 100 * c.sigma(1),
                  100 * c.sigma(2), 100 * c.bias_m, 100 * c.sigma(3), 100 * c.rms_m,
                  c.status == ips::AnchorCalibration::Status::kOk ? ips::anchor_unknowns_word(c.unknowns)
                                                                  : ips::anchor_calibration_status_word(c.status));
    }
    std::printf("%d of %zu anchors calibrated -> %s\n", calibrated, results.size(), o.out.c_str());
  }
  return calibrated > 0 ? 0 : 1;
}

std::function<int()> setup_ranging(CLI::App& sub) {
  sub.require_subcommand(1);
  CLI::App* calibrate = sub.add_subcommand(
      "calibrate", "Each anchor's position and range bias from ranges taken where the tag's position was known");
  auto o = std::make_shared<CalibrateOptions>();
  calibrate->add_option("--anchors", o->anchors, "anchors.yaml: anchors: [{id, x, y, z}], as configured (the start)")
      ->required()
      ->check(CLI::ExistingFile);
  calibrate->add_option("--ranges", o->ranges, "ranges.csv: fix,reference,range[,sigma,...] (ips trilaterate's)")
      ->required()
      ->check(CLI::ExistingFile);
  calibrate
      ->add_option("--positions", o->positions,
                   "positions.csv: fix,x,y,z[,sigma]: where the tag was at each fix (cameras, motion capture); "
                   "other columns are ignored")
      ->required()
      ->check(CLI::ExistingFile);
  calibrate->add_option("--out", o->out, "the calibrated anchors.yaml: anchors: [{id, x, y, z, bias}]")->required();
  calibrate->add_flag("--bias-only", o->bias_only, "keep the configured positions, estimate the biases only");
  calibrate->add_option("--position-sigma", o->position_sigma, "1-sigma of a position without a sigma column (m)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  calibrate->add_option("--robust", o->robust_sigmas, "Huber loss beyond this many sigmas (0: plain least squares)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  calibrate->add_flag("--json", o->json, "print the results as JSON instead of a table");
  return [o] { return run_calibrate(*o); };
}

IPS_REGISTER_COMMAND("ranging", "Ranging tools: calibrate the anchors (positions and biases) against known positions",
                     setup_ranging);

}  // namespace cmd_ranging
