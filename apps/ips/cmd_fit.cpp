// `ips fit`: fit one mapper per camera on a calibration CSV and write the model file.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "command.h"
#include "error_table.h"
#include "ips/config/config.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "ips/mapping/cross_validation.h"
#include "ips/mapping/model_file.h"

#include <nlohmann/json.hpp>

namespace ips::cli {
namespace cmd_fit {  // named, not anonymous: unique in a unity build

nlohmann::json training_summary(const CalibData& data, const CalibSet& set, const Mapper& mapper,
                                const FitOptions& options) {
  Eigen::Vector3d cmin = set.cam[0], cmax = set.cam[0], wmin = set.world[0], wmax = set.world[0];
  for (std::size_t i = 0; i < set.cam.size(); ++i) {
    cmin = cmin.cwiseMin(set.cam[i]);
    cmax = cmax.cwiseMax(set.cam[i]);
    wmin = wmin.cwiseMin(set.world[i]);
    wmax = wmax.cwiseMax(set.world[i]);
  }
  auto arr = [](const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  const CameraErrors fit_errors = compare_points(predict_points(mapper, set.cam, set.world), set.world);
  return {{"data", data.source},    {"n", set.cam.size()},
          {"cam_min", arr(cmin)},   {"cam_max", arr(cmax)},
          {"world_min", arr(wmin)}, {"world_max", arr(wmax)},
          {"seed", options.seed},   {"fit_errors", errors_to_json(fit_errors)}};
}

// Why `auto` chose what it chose, from the CV table it stores in the model file.
void explain_auto(const std::string& camera, const nlohmann::json& params) {
  const int folds = params["folds"].get<int>();
  const std::string metric = params["metric"].get<std::string>();
  const std::string key = metric == "2d" ? "err2d_mean" : "err3d_mean";
  std::vector<std::pair<double, std::string>> ranked;
  for (const auto& [name, row] : params["cv_mean_error"].items())
    if (row.contains(key)) ranked.emplace_back(row[key].get<double>(), name);
  std::sort(ranked.begin(), ranked.end());
  std::string next;
  for (std::size_t i = 1; i < ranked.size() && i < 4; ++i) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s%s %.2f", i > 1 ? ", " : "", ranked[i].second.c_str(), ranked[i].first * 100);
    next += buf;
  }
  std::printf("%s: auto chose '%s': least %d-fold cross-validated mean %s error, %.2f cm (next: %s cm)\n",
              camera.c_str(), params["chosen"].get<std::string>().c_str(), folds, metric == "2d" ? "2-D" : "3-D",
              ranked.empty() ? NAN : ranked[0].first * 100, next.c_str());
}

std::function<int()> setup(CLI::App& sub) {
  struct Args {
    std::string data, method, out, metric = "3d", heights, config;
    std::vector<std::string> cameras;
    std::uint64_t seed = 1;
    int folds = 10;
  };
  auto args = std::make_shared<Args>();
  sub.add_option("--data", args->data, "calibration CSV (camera,xc,yc,zc,xw,yw,zw)")->required();
  sub.add_option("--method", args->method, "rt|pr|rt+pr|ann|rt+ann|ki|rt+ki|kr|rt+kr|plane|auto")->required();
  sub.add_option("--out", args->out, "model file to write (JSON)")->required();
  sub.add_option("--camera", args->cameras, "fit only this camera (repeatable; default all)");
  sub.add_option("--seed", args->seed, "seed of the stochastic fits (ann)")->capture_default_str();
  sub.add_option("--metric", args->metric, "auto: pick by 3d or 2d CV error")->capture_default_str();
  sub.add_option("--folds", args->folds, "auto: k of its k-fold cross-validation")->capture_default_str();
  auto* heights = sub.add_option("--heights", args->heights,
                                 "auto: known (default, the daemon's normal case: markers.height set; plane "
                                 "competes) or unknown (plane cannot be used and does not compete)");
  sub.add_option("--config", args->config, "auto: the ipsd configuration tells whether the marker heights are known")
      ->excludes(heights);
  return [args] {
    FitOptions options;
    options.seed = args->seed;
    options.metric = parse_metric(args->metric, "--metric");
    options.folds = args->folds;
    if (options.folds < 2) throw InputError("--folds: must be at least 2");
    std::string heights_reason = "--heights known, the default";
    if (!args->heights.empty()) {
      if (args->heights != "known" && args->heights != "unknown")
        throw InputError("--heights: expected known or unknown, got '" + args->heights + "'");
      options.heights_known = args->heights == "known";
      heights_reason = "--heights " + args->heights;
    } else if (!args->config.empty()) {
      // The same test the daemon applies before it accepts a mapper that needs heights.
      const DaemonConfig config =
          load_config(args->config, ConfigChecks{.intrinsics_exist = true, .model_file_exists = false});
      options.heights_known = !std::isnan(config.markers.height);
      for (const auto& [id, info] : config.markers.ids)
        options.heights_known = options.heights_known || !std::isnan(info.height);
      heights_reason =
          args->config + (options.heights_known ? " gives marker heights (markers.height / ids.<id>.height)"
                                                : " gives no marker height");
    }
    make_mapper(args->method);  // unknown name -> error before reading anything
    const CalibData data = load_calib_csv(args->data);
    std::vector<const CalibSet*> sets;
    if (args->cameras.empty()) {
      for (const auto& set : data.cameras) sets.push_back(&set);
    } else {
      for (const auto& camera : args->cameras) {
        const CalibSet* set = &require_camera(data, camera);
        if (std::find(sets.begin(), sets.end(), set) == sets.end()) sets.push_back(set);
      }
    }
    // Check every camera before fitting anything, so a bad file fails fast.
    for (const CalibSet* set : sets) {
      const auto mapper = make_mapper(args->method);
      if (set->cam.size() < mapper->min_points())
        throw InputError(data.source + ":" + std::to_string(set->lines.back()) + ": camera '" + set->camera + "' has " +
                         std::to_string(set->cam.size()) + " pairs; method '" + args->method + "' needs at least " +
                         std::to_string(mapper->min_points()));
    }
    ModelSet models;
    ErrorRows rows;
    for (const CalibSet* set : sets) {
      CameraModelEntry entry;
      entry.mapper = make_mapper(args->method);
      try {
        entry.mapper->fit(set->cam, set->world, options);
      } catch (const InputError& e) {
        throw InputError(data.source + ": camera '" + set->camera + "': " + e.what());
      }
      entry.training = training_summary(data, *set, *entry.mapper, options);
      rows.emplace_back(set->camera, compare_points(predict_points(*entry.mapper, set->cam, set->world), set->world));
      models.cameras.emplace(set->camera, std::move(entry));
    }
    save_model_file(models, args->out);
    std::printf("fitted '%s' on %s -> %s\ntraining-set errors (not a held-out estimate; use `ips cv`):\n",
                args->method.c_str(), data.source.c_str(), args->out.c_str());
    print_error_table("camera", rows);
    if (args->method == "auto") {
      std::printf("marker heights %s (%s): %s\n", options.heights_known ? "known" : "unknown", heights_reason.c_str(),
                  options.heights_known ? "plane competed, scored by its true error (its z is the known height)"
                                        : "plane cannot be used without them and did not compete");
      for (const CalibSet* set : sets) explain_auto(set->camera, models.cameras.at(set->camera).mapper->to_json());
    }
    return 0;
  };
}

IPS_REGISTER_COMMAND("fit", "Fit a camera->world mapper per camera on calibration pairs and write the model file",
                     setup);

}  // namespace cmd_fit
}  // namespace ips::cli
