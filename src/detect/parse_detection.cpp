#include "detect/parse_detection.h"

#include <sstream>

#include "core/map_reader.h"

namespace ips::config_detail {

DetectorOptions parse_detection(const YAML::Node& n, const std::string& file, TrackerOptions& tracking) {
  MapReader r(n, "detection", file);
  DetectorOptions d;
  auto int_in = [&](const std::string& k, int& value, int lo, int hi) {
    r.get(k, value);
    if (r.has(k) && (value < lo || value > hi))
      r.fail(r.raw()[k], r.key(k), "must be " + std::to_string(lo) + ".." + std::to_string(hi));
  };
  auto number_in = [&](const std::string& k, double& value, double lo, double hi) {
    r.get(k, value);
    if (r.has(k) && !(value >= lo && value <= hi)) {
      std::ostringstream range;
      range << lo << ".." << hi;
      r.fail(r.raw()[k], r.key(k), "must be " + range.str());
    }
  };
  int_in("detect_scale", d.detect_scale, 0, 8);
  number_in("min_marker_px", d.min_marker_px, 0.0, 100000.0);
  if (r.has("min_perimeter_px")) {  // the older form of min_marker_px: 4 sides
    double perimeter = 0;
    r.get_number("min_perimeter_px", perimeter, 0.0, true);
    if (r.has("min_marker_px"))
      r.fail(r.raw()["min_perimeter_px"], r.key("min_perimeter_px"), "give min_marker_px only");
    d.min_marker_px = perimeter / 4;
  }
  if (r.has("threshold_windows")) {
    const YAML::Node w = r.node("threshold_windows");
    if (!w.IsSequence() || w.size() == 0)
      r.fail(w, "detection.threshold_windows", "expected a non-empty list of odd window sizes, e.g. [9] or [9, 19]");
    d.threshold_windows.clear();
    for (std::size_t i = 0; i < w.size(); ++i) {
      const std::string key = "detection.threshold_windows[" + std::to_string(i) + "]";
      int v = 0;
      try {
        v = w[i].as<int>();
      } catch (const YAML::Exception&) {
        r.fail(w[i], key, "expected an integer");
      }
      if (v < 3 || v % 2 == 0 || v > 255) r.fail(w[i], key, "window sizes must be odd, 3..255");
      d.threshold_windows.push_back(v);
    }
  }
  number_in("threshold_constant", d.threshold_constant, 0.0, 255.0);
  r.get_number("max_perimeter_rate", d.max_perimeter_rate, 0.0, true);
  number_in("error_correction_rate", d.error_correction_rate, 0.0, 1.0);
  number_in("max_border_error_rate", d.max_border_error_rate, 0.0, 1.0);
  int_in("max_ambiguous_cells", d.max_ambiguous_cells, -1, 1000);
  number_in("cell_ambiguity", d.cell_ambiguity, 0.0, 0.5);
  int_in("min_clear_margin", d.min_clear_margin, 1, 64);
  number_in("min_contrast", d.min_contrast, 0.0, 255.0);
  d.refinement = pick<CornerRefinement>(
      r, "refinement",
      {{"edges", CornerRefinement::kEdges}, {"subpix", CornerRefinement::kSubPix}, {"none", CornerRefinement::kNone}},
      d.refinement, false);
  int_in("refine_half_window_px", d.refine_half_window_px, 1, 32);
  r.get("tracking", tracking.enabled);
  int_in("full_search_period", tracking.full_search_period, 1, 1000);
  number_in("roi_margin", tracking.roi_margin, 0.25, 100.0);
  r.finish();
  return d;
}

}  // namespace ips::config_detail
