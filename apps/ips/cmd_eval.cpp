// `ips eval`: errors of a model file on calibration pairs (held-out data), per camera.
#include <cstdio>
#include <string>

#include "command.h"
#include "error_table.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "ips/mapping/cross_validation.h"
#include "ips/mapping/model_file.h"

namespace ips::cli {
namespace cmd_eval {  // named, not anonymous: unique in a unity build

std::function<int()> setup(CLI::App& sub) {
  struct Args {
    std::string model, data;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  sub.add_option("--model", args->model, "model file written by `ips fit`")->required();
  sub.add_option("--data", args->data, "calibration CSV to evaluate on")->required();
  sub.add_flag("--json", args->json, "print JSON (metres) instead of the table (cm)");
  return [args] {
    const ModelSet models = load_model_file(args->model);
    const CalibData data = load_calib_csv(args->data);
    ErrorRows rows;
    for (const auto& set : data.cameras) {
      const Mapper* mapper = models.find(set.camera);
      if (mapper == nullptr) {
        std::string have;
        for (const auto& [name, entry] : models.cameras) have += (have.empty() ? "" : ", ") + name;
        throw InputError(data.source + ":" + std::to_string(set.lines.front()) + ": camera '" + set.camera +
                         "' is not in " + args->model + " (it has: " + have + ")");
      }
      rows.emplace_back(set.camera, compare_points(predict_points(*mapper, set.cam, set.world), set.world));
    }
    if (args->json) {
      print_error_json(rows);
    } else {
      std::printf("model %s on %s\n", args->model.c_str(), data.source.c_str());
      print_error_table("camera", rows);
    }
    return 0;
  };
}

IPS_REGISTER_COMMAND("eval", "Evaluate a model file on calibration pairs: 3D and 2D error per camera", setup);

}  // namespace cmd_eval
}  // namespace ips::cli
