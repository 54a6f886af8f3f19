#include "ips/geometry/marker_settings.h"

namespace ips {

MarkerSizes MarkerConfig::sizes() const {
  MarkerSizes s;
  s.default_length = edge_length;
  for (const auto& [id, info] : ids)
    if (!std::isnan(info.edge_length)) s.by_id[id] = info.edge_length;
  return s;
}

double MarkerConfig::height_of(int id) const {
  auto it = ids.find(id);
  if (it != ids.end() && !std::isnan(it->second.height)) return it->second.height;
  return height;
}

bool MarkerConfig::published(int id) const {
  auto it = ids.find(id);
  return it == ids.end() || it->second.publish;
}

}  // namespace ips
