// `ips compare`: every mapping method side by side per camera, on a held-out file if given,
// cross-validated on the training file otherwise — the table a user reads to pick a model.
// `auto` is not a row: it picks the best of these rows by k-fold CV (nested CV would be slow).
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "command.h"
#include "error_table.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "ips/mapping/cross_validation.h"

namespace ips::cli {
namespace cmd_compare {  // named, not anonymous: unique in a unity build

std::function<int()> setup(CLI::App& sub) {
  struct Args {
    std::string train, test;
    int folds = 10;
    bool loo = false, json = false;
    std::uint64_t seed = 1;
  };
  auto args = std::make_shared<Args>();
  sub.add_option("--train", args->train, "calibration CSV to fit on")->required();
  sub.add_option("--test", args->test, "held-out calibration CSV to score on (default: cross-validate)");
  auto* folds =
      sub.add_option("--folds", args->folds, "k of k-fold cross-validation (without --test)")->capture_default_str();
  sub.add_flag("--loo", args->loo, "leave-one-out cross-validation (without --test)")->excludes(folds);
  sub.add_flag("--json", args->json, "print JSON (metres) instead of the tables (cm)");
  sub.add_option("--seed", args->seed, "seed of the stochastic fits (ann)")->capture_default_str();
  return [args] {
    FitOptions options;
    options.seed = args->seed;
    if (!args->loo && args->folds < 2) throw InputError("--folds: must be at least 2");
    const CalibData train = load_calib_csv(args->train);
    const bool held_out = !args->test.empty();
    CalibData test;
    if (held_out) {
      test = load_calib_csv(args->test);
      for (const auto& set : test.cameras) require_camera(train, set.camera);
    }
    const CalibData& scored = held_out ? test : train;
    const std::string mode =
        held_out
            ? "held-out on " + test.source
            : (args->loo ? std::string("leave-one-out") : std::to_string(args->folds) + "-fold") + " cross-validation";
    nlohmann::json doc = {{"mode", mode}, {"cameras", nlohmann::json::object()}};
    if (!args->json) std::printf("%s, fitted on %s\n", mode.c_str(), train.source.c_str());
    for (const auto& set : scored.cameras) {
      const CalibSet& fit_set = require_camera(train, set.camera);
      ErrorRows rows;
      nlohmann::json cam_doc = nlohmann::json::object();
      std::vector<std::string> skipped;
      for (const auto& method : mapper_names()) {
        if (method == "auto") continue;
        try {
          CameraErrors e;
          if (held_out) {
            auto mapper = make_mapper(method);
            if (fit_set.cam.size() < mapper->min_points())
              throw InputError("needs at least " + std::to_string(mapper->min_points()) + " pairs");
            mapper->fit(fit_set.cam, fit_set.world, options);
            e = compare_points(predict_points(*mapper, set.cam, set.world), set.world);
          } else {
            e = cross_validate(method, set.cam, set.world, args->loo ? 0 : args->folds, options);
          }
          rows.emplace_back(method, e);
          cam_doc[method] = errors_to_json(e);
        } catch (const InputError& e) {
          skipped.push_back(method + ": " + e.what());
          cam_doc[method] = {{"error", e.what()}};
        }
      }
      doc["cameras"][set.camera] = cam_doc;
      if (!args->json) {
        std::printf("\ncamera %s (%zu training pairs%s)\n", set.camera.c_str(), fit_set.cam.size(),
                    held_out ? (", " + std::to_string(set.cam.size()) + " test pairs").c_str() : "");
        print_error_table("method", rows);
        for (const auto& s : skipped) std::printf("  skipped %s\n", s.c_str());
      }
    }
    if (args->json) std::printf("%s\n", doc.dump().c_str());
    return 0;
  };
}

IPS_REGISTER_COMMAND("compare", "Compare every mapping method per camera (held-out with --test, else cross-validated)",
                     setup);

}  // namespace cmd_compare
}  // namespace ips::cli
