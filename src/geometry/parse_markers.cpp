#include "geometry/parse_markers.h"

#include <array>
#include <cmath>

#include "core/map_reader.h"

namespace ips::config_detail {

MarkerConfig parse_markers(const YAML::Node& n, const std::string& file) {
  MapReader r(n, "markers", file);
  MarkerConfig m;
  r.get("dictionary", m.dictionary);
  r.get_number("edge_length", m.edge_length, 0.0, true);
  if (r.has("height")) r.get("height", m.height);
  if (r.has("ids")) {
    const YAML::Node ids = r.node("ids");
    if (!ids.IsMap()) r.fail(ids, "markers.ids", "expected a mapping of marker id -> settings");
    for (const auto& kv : ids) {
      int id = -1;
      if (!kv.first.IsScalar()) r.fail(kv.first, "markers.ids", "marker id must be a non-negative integer");
      const std::string id_text = kv.first.as<std::string>();
      try {
        id = kv.first.as<int>();
      } catch (const YAML::Exception&) {
        r.fail(kv.first, "markers.ids." + id_text, "marker id must be a non-negative integer");
      }
      if (id < 0) r.fail(kv.first, "markers.ids." + id_text, "marker id must be a non-negative integer");
      MapReader e(kv.second, "markers.ids." + id_text, file);
      MarkerInfo info;
      e.get("name", info.name);
      if (e.has("edge_length")) e.get_number("edge_length", info.edge_length, 0.0, true);
      if (e.has("height")) e.get("height", info.height);
      if (e.has("fixed")) {
        const YAML::Node f = e.node("fixed");
        std::array<double, 3> p{};
        bool ok = f.IsSequence() && f.size() == 3;
        for (std::size_t i = 0; ok && i < 3; ++i) {
          try {
            p[i] = f[i].as<double>();
            ok = f[i].IsScalar() && std::isfinite(p[i]);
          } catch (const YAML::Exception&) {
            ok = false;
          }
        }
        if (!ok) e.fail(f, e.key("fixed"), "expected [x, y, z]: three finite numbers (world metres)");
        info.fixed = p;
        // A fixed marker's height is known: its surveyed z (unless given explicitly).
        if (std::isnan(info.height)) info.height = p[2];
      }
      info.publish = !info.fixed;  // fixed markers are not robots unless configured to be
      e.get("publish", info.publish);
      e.finish();
      m.ids[id] = info;
    }
  }
  r.finish();
  return m;
}

}  // namespace ips::config_detail
