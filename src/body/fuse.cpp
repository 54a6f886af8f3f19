// One pose per body per instant from all its markers and cameras (see body_estimate.h).
//
// Yaw first: views whose face is unique give it directly; a cube side (four faces share one id
// and one class) takes the face whose yaw lies nearest that reference, or the body's own yaw
// from the last second. Markers far enough apart on the body then give the yaw by their
// baseline (a 2-D rigid fit of their fused centres), which beats any single marker's own
// heading; otherwise the per-view poses are fused with the configured method (mean, area,
// gauss, median), exactly as plain markers are.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "angle.h"
#include "ips/body/body_estimate.h"

namespace ips {
namespace {

using body_detail::wrap;

WorldObservation as_world(const BodyObservation& o, const Eigen::Vector3d& p, double yaw) {
  WorldObservation w;
  w.id = o.body;
  w.camera_index = o.camera_index;
  w.p_world = p;
  w.yaw = yaw;
  w.area_px = o.area_px;
  w.t_mono_ns = o.t_mono_ns;
  w.t_real_ns = o.t_real_ns;
  return w;
}

}  // namespace

std::vector<FusedBody> BodyEstimator::fuse(std::span<const BodyObservation> observations, const FusionMethod& method) {
  std::map<int, std::vector<const BodyObservation*>> by_body;
  for (const auto& o : observations)
    if (o.body >= 0 && o.body < static_cast<int>(bodies_.size()) && !o.faces.empty()) by_body[o.body].push_back(&o);
  std::vector<FusedBody> out;
  for (const auto& [b, obs] : by_body) {
    const BodyDef& def = bodies_[static_cast<std::size_t>(b)];
    Memory& mem = memory_[static_cast<std::size_t>(b)];
    const std::int64_t t_now = obs.front()->t_mono_ns;

    // The reference yaw: views of unique faces, else the body's recent yaw.
    double s = 0, c = 0;
    for (const auto* o : obs)
      if (o->faces.size() == 1) {
        s += o->area_px * std::sin(o->yaws[0]);
        c += o->area_px * std::cos(o->yaws[0]);
      }
    bool has_ref = s != 0 || c != 0;
    double ref = std::atan2(s, c);
    if (!has_ref && mem.valid &&
        std::llabs(t_now - mem.t_ns) <= static_cast<std::int64_t>(options_.yaw_memory_s * 1e9)) {
      has_ref = true;
      ref = mem.yaw;
    }

    // Resolve each view to one face (or to position only).
    struct Resolved {
      const BodyObservation* o;
      int face;  // -1: face unknown (position only)
      int k;     // candidate index
    };
    std::vector<Resolved> res;
    for (const auto* o : obs) {
      if (o->faces.size() == 1) {
        res.push_back({o, o->faces[0], 0});
        continue;
      }
      if (has_ref) {
        std::size_t best = 0;
        for (std::size_t k = 1; k < o->yaws.size(); ++k)
          if (std::abs(wrap(o->yaws[k] - ref)) < std::abs(wrap(o->yaws[best] - ref))) best = k;
        // Within the tolerance of the reference: that face. Farther (the robot turned more
        // since its yaw was last known): the face stays unknown, the view gives position only.
        if (std::abs(wrap(o->yaws[best] - ref)) <= options_.side_tolerance) {
          res.push_back({o, o->faces[best], static_cast<int>(best)});
          continue;
        }
      }
      // No yaw to tell the faces apart: usable for position if every candidate agrees (a cube).
      bool agree = true;
      for (const auto& p : o->positions) agree = agree && (p - o->positions[0]).norm() < 0.005;
      if (agree) res.push_back({o, -1, 0});
    }
    if (res.empty()) continue;

    FusedBody f;
    f.body = b;
    f.name = def.name;
    std::set<int> ids;
    for (const auto& r : res) {
      ids.insert(r.o->id);
      if (r.o->camera_index >= 0 && r.o->camera_index < 32) f.camera_mask |= 1u << r.o->camera_index;
      f.quality += r.o->area_px;
    }
    f.marker_ids.assign(ids.begin(), ids.end());
    f.observations = static_cast<int>(res.size());

    // Position of every view, and the yaw of those whose face is known.
    std::vector<WorldObservation> pos, yaw;
    for (const auto& r : res) {
      const auto k = static_cast<std::size_t>(r.k);
      pos.push_back(as_world(*r.o, r.o->positions[k], r.o->yaws[k]));
      if (r.face >= 0) yaw.push_back(pos.back());
    }
    const FusedMarker fp = fuse_marker(pos, method);
    f.pose.position = fp.p_world;
    f.spread = fp.spread;
    f.t_mono_ns = fp.t_mono_ns;
    f.t_real_ns = fp.t_real_ns;
    if (!yaw.empty()) {
      f.has_yaw = true;
      f.pose.yaw = fuse_marker(yaw, method).yaw;
    }

    // Markers far enough apart: yaw (and position) from their baseline.
    std::map<int, std::vector<WorldObservation>> centres;
    for (const auto& r : res)
      if (r.face >= 0) centres[r.face].push_back(as_world(*r.o, r.o->marker_centre, 0.0));
    if (def.ground && centres.size() >= 2) {
      std::vector<Eigen::Vector2d> bp, wp;
      for (const auto& [face, group] : centres) {
        bp.push_back(def.markers[static_cast<std::size_t>(face)].position.head<2>());
        wp.push_back(fuse_marker(group, method).p_world.head<2>());
      }
      double span = 0;
      for (std::size_t i = 0; i < bp.size(); ++i)
        for (std::size_t j = i + 1; j < bp.size(); ++j) span = std::max(span, (bp[i] - bp[j]).norm());
      if (span >= options_.baseline_min) {
        Eigen::Vector2d bm = Eigen::Vector2d::Zero(), wm = Eigen::Vector2d::Zero();
        for (std::size_t i = 0; i < bp.size(); ++i) {
          bm += bp[i] / static_cast<double>(bp.size());
          wm += wp[i] / static_cast<double>(wp.size());
        }
        double num = 0, den = 0;
        for (std::size_t i = 0; i < bp.size(); ++i) {
          const Eigen::Vector2d p = bp[i] - bm, q = wp[i] - wm;
          num += q.y() * p.x() - q.x() * p.y();
          den += q.x() * p.x() + q.y() * p.y();
        }
        const double psi = std::atan2(num, den);
        const Eigen::Rotation2Dd R(psi);
        f.has_yaw = true;
        f.pose.yaw = psi;
        f.pose.position.head<2>() = wm - R * bm;
      }
    }

    if (def.ground) {
      f.pose.position.z() = 0.0;
      f.pose.q = Eigen::AngleAxisd(f.pose.yaw, Eigen::Vector3d::UnitZ());
    } else {
      // Mean of the views' orientations (signs aligned to the first), method-weighted.
      Eigen::Vector4d sum = Eigen::Vector4d::Zero();
      Eigen::Quaterniond first;
      bool have = false;
      for (const auto& r : res) {
        if (r.face < 0) continue;
        Eigen::Quaterniond q = r.o->qs[static_cast<std::size_t>(r.k)];
        if (!have) {
          first = q;
          have = true;
        }
        if (q.dot(first) < 0) q.coeffs() = -q.coeffs();
        const double w =
            method.weight ? std::max(1e-12, method.weight(as_world(*r.o, Eigen::Vector3d::Zero(), 0.0))) : 1.0;
        sum += w * q.coeffs();
      }
      if (have) {
        f.pose.q.coeffs() = sum.normalized();
        const Eigen::Matrix3d R = f.pose.q.toRotationMatrix();
        f.pose.yaw = std::atan2(R(1, 0), R(0, 0));
      }
    }
    if (f.has_yaw) {
      mem.yaw = f.pose.yaw;
      mem.q = f.pose.q;
      mem.t_ns = f.t_mono_ns;
      mem.valid = true;
    }
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace ips
