// `ips survey`: camera poses from an `ips record` wand session and >= 3 floor references, by
// bundle adjustment (src/survey). Writes a model file whose cameras carry the `plane` model,
// which ipsd loads as it is.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "command.h"
#include "ips/config/config.h"
#include "ips/config/source_factory.h"
#include "ips/core/error.h"
#include "ips/mapping/model_file.h"
#include "ips/survey/survey.h"

namespace fs = std::filesystem;

namespace ips::cli {
namespace cmd_survey {  // named, not anonymous: unique in a unity build

struct Args {
  std::string session, references, out, report, config;
  double still_px = 0.5, min_still_s = 0.3, huber_px = 1.0;
  int min_instants = 6;
};

void check_parent(const std::string& option, const std::string& path) {
  const fs::path parent = fs::absolute(path).parent_path();
  if (!fs::is_directory(parent)) throw InputError(option + " " + path + ": no such directory " + parent.string());
}

int run(const Args& a) {
  if (!(a.still_px > 0) || !(a.min_still_s > 0) || !(a.huber_px > 0))
    throw InputError("--still-px, --min-still, --huber: must be > 0");
  check_parent("--out", a.out);
  if (!a.report.empty()) check_parent("--report", a.report);
  const auto refs = survey::load_references(a.references);
  survey::Session session = survey::load_session(a.session);
  const std::string config_path = a.config.empty() ? session.config : a.config;
  const DaemonConfig config =
      load_config(config_path, ConfigChecks{.intrinsics_exist = true, .model_file_exists = false});

  // The session's cameras must be this config's, with the same lenses.
  survey::SurveyInput input;
  std::vector<std::pair<std::string, CameraModel>> models;
  for (const auto& sc : session.cameras) {
    const CameraConfig* found = nullptr;
    for (const auto& c : config.cameras)
      if (c.name == sc.name) found = &c;
    if (found == nullptr)
      throw InputError(a.session + ": camera '" + sc.name + "' is not in " + config_path +
                       " (a session from another configuration)");
    survey::SurveyCamera cam{found->name, found->model.empty() ? found->name : found->model, load_intrinsics(*found)};
    models.emplace_back(cam.name, cam.intrinsics);
    input.cameras.push_back(cam);
  }
  const std::string fingerprint = survey::camera_fingerprint(models);
  if (fingerprint != session.fingerprint)
    throw InputError(a.session + "/session.txt: recorded with other cameras or intrinsics than " + config_path +
                     " has now (fingerprint " + session.fingerprint + ", the config gives " + fingerprint +
                     "); record again, or pass the session's --config");

  survey::StillOptions still;
  still.still_px = a.still_px;
  still.min_still_s = a.min_still_s;
  const auto periods = survey::find_still_periods(session, still);
  input.instants = survey::group_instants(periods, 0.1);
  input.references = refs;
  input.huber_px = a.huber_px;
  const MarkerSizes sizes = config.markers.sizes();
  int wand_instants = 0;
  for (const auto& in : input.instants) {
    input.edge_length[in.id] = sizes.length_of(in.id);
    bool is_ref = false;
    for (const auto& r : refs) is_ref = is_ref || r.id == in.id;
    if (!is_ref && in.views.size() >= 2) ++wand_instants;
  }
  std::printf("ips survey: %zu camera(s), %zu still period(s), %zu instant(s), %d of the wand seen by >= 2 cameras\n",
              session.cameras.size(), periods.size(), input.instants.size(), wand_instants);
  if (wand_instants < a.min_instants)
    throw InputError(a.session + ": only " + std::to_string(wand_instants) +
                     " still wand instant(s) seen by two or more cameras (need " + std::to_string(a.min_instants) +
                     "); record again, pausing the wand ~1 s at a time where cameras overlap");

  const survey::SurveyResult result = survey::run_survey(input);

  std::printf("bundle adjustment: %d instants, %d iterations, RMS %.3f px -> %.3f px\n", result.instants,
              result.iterations, result.initial_rms_px, result.final_rms_px);
  std::printf("%-12s %9s %9s %9s %8s %6s %5s %22s\n", "camera", "x m", "y m", "z m", "rms px", "views", "refs",
              "sigma x/y/z mm");
  ModelSet set;
  for (const auto& c : result.cameras) {
    std::printf("%-12s %9.4f %9.4f %9.4f %8.3f %6d %5d %8.2f %6.2f %6.2f\n", c.name.c_str(), c.centre.x(), c.centre.y(),
                c.centre.z(), c.rms_px, c.observations, c.references_seen, c.sigma.x() * 1e3, c.sigma.y() * 1e3,
                c.sigma.z() * 1e3);
    nlohmann::json params = {{"R", nlohmann::json::array()},
                             {"t", {c.centre.x(), c.centre.y(), c.centre.z()}},
                             {"radial_terms", 0},
                             {"k1", 0.0},
                             {"k2", 0.0}};
    for (int r = 0; r < 3; ++r) params["R"].push_back({c.R_wc(r, 0), c.R_wc(r, 1), c.R_wc(r, 2)});
    CameraModelEntry entry;
    entry.mapper = make_mapper("plane");
    entry.mapper->from_json(params);
    entry.training = {{"source", "ips survey"},
                      {"session", fs::absolute(a.session).lexically_normal().string()},
                      {"rms_px", c.rms_px},
                      {"views", c.observations},
                      {"references_seen", c.references_seen},
                      {"sigma_centre_m", {c.sigma.x(), c.sigma.y(), c.sigma.z()}}};
    if (!c.covariance_ok) entry.training["sigma_centre_m"] = nullptr;
    set.cameras[c.model] = std::move(entry);
  }
  std::printf(
      "references: where each camera puts them minus the known position, in the fit and with the\n"
      "survey solved without that reference (left out: how well the references agree):\n");
  for (const auto& r : result.references)
    for (const auto& [name, e] : r.residual) {
      const auto lo = r.left_out.find(name);
      char loo[80] = "left out: (solve failed)";
      if (lo != r.left_out.end())
        std::snprintf(loo, sizeof loo, "left out: dx %+.1f dy %+.1f mm (%.1f mm)", lo->second.x() * 1e3,
                      lo->second.y() * 1e3, lo->second.norm() * 1e3);
      std::printf("  marker %d (%.3f, %.3f, %.3f) in %s: fit %.2f mm; %s\n", r.id, r.known.x(), r.known.y(),
                  r.known.z(), name.c_str(), e.norm() * 1e3, loo);
    }
  for (auto& [model, entry] : set.cameras)
    for (const auto& r : result.references)
      for (const auto& [name, e] : r.residual)
        for (const auto& c : input.cameras)
          if (c.name == name && c.model == model) {
            nlohmann::json j = {{"known", {r.known.x(), r.known.y(), r.known.z()}}, {"residual_m", {e.x(), e.y()}}};
            const auto lo = r.left_out.find(name);
            if (lo != r.left_out.end()) j["left_out_m"] = {lo->second.x(), lo->second.y()};
            entry.training["references"][std::to_string(r.id)] = j;
          }
  save_model_file(set, a.out);
  std::printf("model: %s\n", a.out.c_str());
  if (!a.report.empty()) {
    survey::write_report_png(result, input, a.report);
    std::printf("report: %s\n", a.report.c_str());
  }
  return 0;
}

IPS_REGISTER_COMMAND(
    "survey", "Camera poses from an `ips record` wand session and floor references (bundle adjustment)",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      sub.add_option("--session", a->session, "Session directory written by `ips record`")->required();
      sub.add_option("--references", a->references,
                     "YAML: references: [{id: N, x: X, y: Y, z: Z}, ...] (>= 3 floor markers, flat)")
          ->required();
      sub.add_option("--out", a->out, "Model file to write (cameras with the `plane` model)")->required();
      sub.add_option("--report", a->report, "Report PNG: top view of cameras, footprints, wand, references");
      sub.add_option("--config", a->config, "ipsd configuration (default: the one the session names)");
      sub.add_option("--still-px", a->still_px, "A still period: corners within this many pixels")
          ->capture_default_str();
      sub.add_option("--min-still", a->min_still_s, "A still period lasts at least this long, seconds")
          ->capture_default_str();
      sub.add_option("--huber", a->huber_px, "Robust (Huber) loss scale, pixels")->capture_default_str();
      sub.add_option("--min-instants", a->min_instants, "Fewest still wand instants seen by >= 2 cameras")
          ->capture_default_str();
      return [a] { return run(*a); };
    });

}  // namespace cmd_survey
}  // namespace ips::cli
