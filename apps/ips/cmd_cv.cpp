// `ips cv`: cross-validated errors of one method per camera (an estimate of held-out error).
#include <cstdio>
#include <string>

#include "command.h"
#include "error_table.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "ips/mapping/cross_validation.h"

namespace ips::cli {
namespace cmd_cv {  // named, not anonymous: unique in a unity build

std::function<int()> setup(CLI::App& sub) {
  struct Args {
    std::string data, method, metric = "3d";
    int folds = 10;
    bool loo = false, json = false;
    std::uint64_t seed = 1;
  };
  auto args = std::make_shared<Args>();
  sub.add_option("--data", args->data, "calibration CSV")->required();
  sub.add_option("--method", args->method, "mapping method (see `ips fit`)")->required();
  auto* folds = sub.add_option("--folds", args->folds, "k of k-fold cross-validation")->capture_default_str();
  sub.add_flag("--loo", args->loo, "leave-one-out instead of k-fold")->excludes(folds);
  sub.add_flag("--json", args->json, "print JSON (metres) instead of the table (cm)");
  sub.add_option("--seed", args->seed, "seed of the stochastic fits (ann)")->capture_default_str();
  sub.add_option("--metric", args->metric, "auto: pick by 3d or 2d CV error")->capture_default_str();
  return [args] {
    FitOptions options;
    options.seed = args->seed;
    options.metric = parse_metric(args->metric, "--metric");
    if (!args->loo && args->folds < 2) throw InputError("--folds: must be at least 2");
    make_mapper(args->method);
    const CalibData data = load_calib_csv(args->data);
    ErrorRows rows;
    for (const auto& set : data.cameras) {
      try {
        rows.emplace_back(set.camera,
                          cross_validate(args->method, set.cam, set.world, args->loo ? 0 : args->folds, options));
      } catch (const InputError& e) {
        throw InputError(data.source + ": camera '" + set.camera + "' (" + std::to_string(set.cam.size()) +
                         " pairs): " + e.what());
      }
    }
    if (args->json) {
      print_error_json(rows);
    } else {
      std::printf("%s, %s cross-validation on %s\n", args->method.c_str(),
                  args->loo ? "leave-one-out" : (std::to_string(args->folds) + "-fold").c_str(), data.source.c_str());
      print_error_table("camera", rows);
    }
    return 0;
  };
}

IPS_REGISTER_COMMAND("cv", "Cross-validate a method per camera on calibration pairs (k-fold or leave-one-out)", setup);

}  // namespace cmd_cv
}  // namespace ips::cli
