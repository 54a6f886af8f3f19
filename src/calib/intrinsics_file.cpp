// The intrinsics file `ips calibrate` writes: the ipsd YAML form (CameraModel::load reads
// it) plus a `calibration:` block that records how it was made.
#include <chrono>
#include <cstdio>
#include <ctime>

#include "ips/calib/calibrate.h"

namespace ips::calib {

std::string model_yaml(const CameraModel& m) {
  const auto& K = m.K();
  const bool fisheye = m.kind() == CameraModel::Kind::kFisheye;
  std::string s =
      std::string("# Camera intrinsics (the ipsd intrinsics form, include/ips/geometry/camera_model.h): OpenCV ") +
      (fisheye ? "fisheye model, D = k1 k2 k3 k4"
               : (m.D().size() == 12 ? "pinhole model, D = k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4"
                                     : "pinhole model, D = k1 k2 p1 p2 k3 k4 k5 k6")) +
      ".\n";
  s += std::string("model: ") + (fisheye ? "fisheye" : "pinhole") + "\n";
  char buf[512];
  std::snprintf(buf, sizeof buf, "image_width: %d\nimage_height: %d\n", m.size().width, m.size().height);
  s += buf;
  std::snprintf(buf, sizeof buf, "K: [%.17g, %.17g, %.17g,\n    %.17g, %.17g, %.17g,\n    %.17g, %.17g, %.17g]\n",
                K(0, 0), K(0, 1), K(0, 2), K(1, 0), K(1, 1), K(1, 2), K(2, 0), K(2, 1), K(2, 2));
  s += buf;
  s += "D: [";
  for (std::size_t i = 0; i < m.D().size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.17g", i ? ", " : "", m.D()[i]);
    s += buf;
  }
  return s + "]\n";
}

std::string intrinsics_yaml(const CalibrationResult& r, const BoardSpec& board, const std::string& source) {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  std::string s = model_yaml(r.model);
  char buf[512];
  s += "calibration:\n";
  s += "  board: \"" + board.str() + "\"\n";
  std::string quoted;  // a YAML double-quoted scalar
  for (char c : source) quoted += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  s += "  source: \"" + quoted + "\"\n";
  int dropped = 0;
  for (const auto& v : r.views) dropped += (!v.used && v.why.rfind("outlier", 0) == 0) ? 1 : 0;
  std::snprintf(buf, sizeof buf,
                "  images: %zu\n  views_used: %d\n  views_dropped_as_outliers: %d\n  rms_px: %.4f\n"
                "  coverage: %.3f\n  max_field_deg: %.2f\n",
                r.views.size(), r.used_views, dropped, r.rms, r.coverage, r.max_field_deg);
  s += buf;
  if (r.turn_back_deg) {
    std::snprintf(buf, sizeof buf, "  polynomial_turns_back_deg: %.2f\n", *r.turn_back_deg);
    s += buf;
  }
  s += std::string("  date: ") + date + "\n";
  return s;
}

}  // namespace ips::calib
