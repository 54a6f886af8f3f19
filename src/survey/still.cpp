// The wand's still periods in each camera and their grouping into instants.
//
// The cameras are not synchronised (each USB camera runs on its own clock phase), so a
// moving wand is seen by two cameras at different places at "the same" time. A still wand is
// not: if camera A saw the marker still over [a0, a1] and camera B over [b0, b1], and the two
// spans overlap, the marker stood at one place over their union, and the mean corners of each
// period are views of one and the same pose. Only such instants enter the bundle adjustment.
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "ips/survey/survey.h"

namespace ips::survey {
namespace {

/// Running mean of the four corners of a period.
struct Mean {
  std::array<Point2, 4> sum{};
  int n = 0;
  void add(const Detection& d) {
    for (std::size_t k = 0; k < 4; ++k) {
      sum[k].x += d.corners[k].x;
      sum[k].y += d.corners[k].y;
    }
    ++n;
  }
  /// True if every corner of `d` lies within `r` pixels of the mean.
  bool near(const Detection& d, double r) const {
    for (std::size_t k = 0; k < 4; ++k)
      if (std::hypot(d.corners[k].x - sum[k].x / n, d.corners[k].y - sum[k].y / n) > r) return false;
    return true;
  }
};

}  // namespace

std::vector<StillPeriod> find_still_periods(const Session& session, const StillOptions& o) {
  std::vector<StillPeriod> out;
  const auto min_ns = static_cast<std::int64_t>(o.min_still_s * 1e9);
  const auto gap_ns = static_cast<std::int64_t>(o.max_gap_s * 1e9);
  for (std::size_t c = 0; c < session.cameras.size(); ++c) {
    std::map<int, std::vector<const Detection*>> by_id;
    for (const auto& d : session.cameras[c].detections) by_id[d.id].push_back(&d);
    for (auto& entry : by_id) {
      // Named variables, not a structured binding: clang 14 cannot capture one in `emit`.
      const int id = entry.first;
      std::vector<const Detection*>& dets = entry.second;
      std::stable_sort(dets.begin(), dets.end(),
                       [](const Detection* a, const Detection* b) { return a->t_ns < b->t_ns; });
      std::size_t start = 0;
      Mean mean;
      auto emit = [&](std::size_t end) {  // [start, end)
        const int n = static_cast<int>(end - start);
        if (n < o.min_frames || dets[end - 1]->t_ns - dets[start]->t_ns < min_ns) return;
        StillPeriod p;
        p.camera = static_cast<int>(c);
        p.id = id;
        p.t0_ns = dets[start]->t_ns;
        p.t1_ns = dets[end - 1]->t_ns;
        p.frames = n;
        for (std::size_t k = 0; k < 4; ++k) p.corners[k] = {mean.sum[k].x / n, mean.sum[k].y / n};
        out.push_back(p);
      };
      if (dets.empty()) continue;
      mean.add(*dets[0]);
      for (std::size_t i = 1; i < dets.size(); ++i) {
        if (dets[i]->t_ns - dets[i - 1]->t_ns <= gap_ns && mean.near(*dets[i], o.still_px)) {
          mean.add(*dets[i]);
          continue;
        }
        emit(i);
        start = i;
        mean = Mean{};
        mean.add(*dets[i]);
      }
      emit(dets.size());
    }
  }
  return out;
}

std::vector<Instant> group_instants(const std::vector<StillPeriod>& periods, double min_overlap_s) {
  const auto min_ns = static_cast<std::int64_t>(min_overlap_s * 1e9);
  std::vector<std::size_t> parent(periods.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < periods.size(); ++i)
    for (std::size_t j = i + 1; j < periods.size(); ++j) {
      const auto& a = periods[i];
      const auto& b = periods[j];
      if (a.id != b.id || a.camera == b.camera) continue;
      if (std::min(a.t1_ns, b.t1_ns) - std::max(a.t0_ns, b.t0_ns) >= min_ns) parent[find(i)] = find(j);
    }
  std::map<std::size_t, Instant> groups;
  for (std::size_t i = 0; i < periods.size(); ++i) {
    Instant& g = groups[find(i)];
    const StillPeriod& p = periods[i];
    if (g.views.empty()) {
      g.id = p.id;
      g.t0_ns = p.t0_ns;
      g.t1_ns = p.t1_ns;
    }
    g.t0_ns = std::max(g.t0_ns, p.t0_ns);
    g.t1_ns = std::min(g.t1_ns, p.t1_ns);
    auto same =
        std::find_if(g.views.begin(), g.views.end(), [&](const StillPeriod& v) { return v.camera == p.camera; });
    if (same == g.views.end())
      g.views.push_back(p);
    else if (p.frames > same->frames)
      *same = p;
  }
  std::vector<Instant> out;
  for (auto& [root, g] : groups) out.push_back(std::move(g));
  std::sort(out.begin(), out.end(),
            [](const Instant& a, const Instant& b) { return a.views.front().t0_ns < b.views.front().t0_ns; });
  return out;
}

}  // namespace ips::survey
