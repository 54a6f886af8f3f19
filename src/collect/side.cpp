// Which side of the line between the two reference points the marker lies on, told by the
// cameras from the pairs collected so far (a rigid map per camera).
#include <cstdio>

#include "ips/collect/collect.h"
#include "ips/core/error.h"
#include "ips/mapping/mapper.h"

namespace ips::collect {

int side_from_cameras(const PairsFile& pairs, const std::vector<std::pair<std::string, Eigen::Vector3d>>& seen,
                      const std::array<Eigen::Vector2d, 2>& candidates, std::string& how) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int n = 0;
  std::string names;
  for (const auto& [name, cam] : seen) {
    std::vector<Eigen::Vector3d> c, w;
    for (const auto& p : pairs.placements())
      for (const auto& [pc_name, pc] : p.cameras)
        if (pc_name == name) {
          c.push_back(pc);
          w.push_back(p.world);
        }
    if (c.size() < 4) continue;
    auto rt = make_mapper("rt");
    try {
      rt->fit(c, w, FitOptions{});
    } catch (const InputError&) {
      continue;  // degenerate pairs so far (e.g. all in a line)
    }
    sum += rt->predict(cam).head<2>();
    ++n;
    names += (names.empty() ? "" : ", ") + name;
  }
  if (n == 0) return -1;
  const Eigen::Vector2d seen_at = sum / n;
  const double d0 = (candidates[0] - seen_at).norm(), d1 = (candidates[1] - seen_at).norm();
  char buf[160];
  std::snprintf(buf, sizeof buf, "the %s side: %s put%s it %.2f m from it, %.2f m from the other",
                d0 <= d1 ? "left" : "right", names.c_str(), n == 1 ? "s" : "", std::min(d0, d1), std::max(d0, d1));
  how = buf;
  return d0 <= d1 ? 0 : 1;
}

}  // namespace ips::collect
