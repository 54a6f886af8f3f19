// The scene's ranging part: anchors, non-line-of-sight zones, tags on markers and bodies, and the ranges a
// tag measures when it fires (docs/simulator.md, "Ranges").
#include <algorithm>
#include <cmath>
#include <set>

#include "ips/sim/scene.h"
#include "sim/scene_reader.h"

namespace ips::sim {

namespace {

Eigen::Vector3d vec3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

/// Does the segment a-b pass through the box? (slab test)
bool crosses(const NlosZone& z, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  double t0 = 0, t1 = 1;
  const Eigen::Vector3d d = b - a;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-15) {
      if (a[i] < z.min[i] || a[i] > z.max[i]) return false;
      continue;
    }
    double u = (z.min[i] - a[i]) / d[i], v = (z.max[i] - a[i]) / d[i];
    if (u > v) std::swap(u, v);
    t0 = std::max(t0, u);
    t1 = std::min(t1, v);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

void read_ranging(const SceneReader& r, const YAML::Node& root, Scene& scene) {
  if (const YAML::Node as = root["anchors"]) {
    if (!as.IsSequence()) r.fail(as, "anchors", "expected a list");
    for (std::size_t i = 0; i < as.size(); ++i) {
      const YAML::Node a = as[i];
      const std::string p = "anchors[" + std::to_string(i) + "].";
      r.only_keys(a, p, {"id", "position", "sigma", "bias", "max_range", "dropout"});
      SceneAnchor an;
      an.id = static_cast<int>(r.integer(a, p, "id", -1, 0, 2147483647));
      if (!a["id"]) r.fail(a, p + "id", "missing");
      for (const auto& other : scene.anchors)
        if (other.id == an.id) r.fail(a["id"], p + "id", "duplicate anchor id " + std::to_string(an.id));
      an.position = vec3(r.numbers(a, p, "position", 3, 3));
      an.sigma = r.number(a, p, "sigma", an.sigma);
      if (!(an.sigma >= 0 && an.sigma <= 10)) r.fail(a["sigma"], p + "sigma", "must be 0..10 m");
      an.bias = r.number(a, p, "bias", an.bias);
      if (std::abs(an.bias) > 10) r.fail(a["bias"], p + "bias", "must be -10..10 m");
      an.max_range = r.number(a, p, "max_range", an.max_range);
      if (!(an.max_range > 0)) r.fail(a["max_range"], p + "max_range", "must be > 0 m");
      an.dropout = r.number(a, p, "dropout", an.dropout);
      if (!(an.dropout >= 0 && an.dropout <= 1)) r.fail(a["dropout"], p + "dropout", "must be 0..1");
      scene.anchors.push_back(an);
    }
  }
  if (const YAML::Node zs = root["nlos_zones"]) {
    if (!zs.IsSequence()) r.fail(zs, "nlos_zones", "expected a list");
    for (std::size_t i = 0; i < zs.size(); ++i) {
      const YAML::Node z = zs[i];
      const std::string p = "nlos_zones[" + std::to_string(i) + "].";
      r.only_keys(z, p, {"min", "max", "bias"});
      NlosZone zone;
      zone.min = vec3(r.numbers(z, p, "min", 3, 3));
      zone.max = vec3(r.numbers(z, p, "max", 3, 3));
      if ((zone.max - zone.min).minCoeff() < 0) r.fail(z["max"], p + "max", "below min on some axis");
      zone.bias = r.number(z, p, "bias", zone.bias);
      if (!(zone.bias > 0 && zone.bias <= 10)) r.fail(z["bias"], p + "bias", "must be > 0 and <= 10 m");
      scene.nlos_zones.push_back(zone);
    }
  }
  if (const YAML::Node ts = root["tags"]) {
    if (!ts.IsSequence()) r.fail(ts, "tags", "expected a list");
    std::set<int> ids;
    for (std::size_t i = 0; i < ts.size(); ++i) {
      const YAML::Node t = ts[i];
      const std::string p = "tags[" + std::to_string(i) + "].";
      r.only_keys(t, p, {"id", "marker", "body", "offset", "height", "range_tags", "sigma", "max_range", "odometry"});
      SceneTag tag;
      if (!t["id"]) r.fail(t, p + "id", "missing");
      tag.id = static_cast<int>(r.integer(t, p, "id", 0, 0, 2147483647));
      if (!ids.insert(tag.id).second) r.fail(t["id"], p + "id", "duplicate tag id " + std::to_string(tag.id));
      if (static_cast<bool>(t["marker"]) == static_cast<bool>(t["body"]))
        r.fail(t, p + "marker", "give either marker (the id of the marker that carries the tag) or body (its name)");
      if (t["body"]) {
        if (!t["body"].IsScalar()) r.fail(t["body"], p + "body", "expected a body's name");
        tag.body = t["body"].Scalar();
        if (std::none_of(scene.bodies.begin(), scene.bodies.end(),
                         [&](const SceneBody& b) { return b.def.name == tag.body; }))
          r.fail(t["body"], p + "body", "no body '" + tag.body + "' in the scene");
        if (t["offset"]) tag.offset = vec3(r.numbers(t, p, "offset", 3, 3));
      } else {
        if (t["offset"]) r.fail(t["offset"], p + "offset", "an offset places a tag on a body");
        tag.marker = static_cast<int>(r.integer(t, p, "marker", 0, 0, 1e9));
        if (std::none_of(scene.markers.begin(), scene.markers.end(),
                         [&](const SceneMarker& m) { return m.id == tag.marker; }))
          r.fail(t["marker"], p + "marker", "no marker " + std::to_string(tag.marker) + " in the scene");
      }
      tag.height = r.number(t, p, "height", tag.height);
      if (std::abs(tag.height) > 10) r.fail(t["height"], p + "height", "must be -10..10 m");
      if (const YAML::Node b = t["range_tags"]) {
        if (!b.IsScalar() || (b.Scalar() != "true" && b.Scalar() != "false"))
          r.fail(b, p + "range_tags", "expected true or false");
        tag.range_tags = b.Scalar() == "true";
      }
      tag.sigma = r.number(t, p, "sigma", tag.sigma);
      if (!(tag.sigma >= 0 && tag.sigma <= 10)) r.fail(t["sigma"], p + "sigma", "must be 0..10 m");
      tag.max_range = r.number(t, p, "max_range", tag.max_range);
      if (!(tag.max_range > 0)) r.fail(t["max_range"], p + "max_range", "must be > 0 m");
      if (t["odometry"]) {
        tag.odometry = r.number(t, p, "odometry", 0.0);
        if (!(*tag.odometry > 0 && *tag.odometry <= 1)) r.fail(t["odometry"], p + "odometry", "must be > 0 and <= 1 m");
      }
      scene.tags.push_back(tag);
    }
  }
}

std::optional<Eigen::Vector3d> Scene::tag_position(std::size_t index, double t) const {
  const SceneTag& tag = tags.at(index);
  if (!tag.body.empty()) {
    for (std::size_t b = 0; b < bodies.size(); ++b)
      if (bodies[b].def.name == tag.body) {
        const BodyPose pose = body_pose_at(b, t);
        return pose.position + pose.q * (tag.offset + Eigen::Vector3d(0, 0, tag.height));
      }
    return std::nullopt;
  }
  const MarkerPose pose = marker_pose(tag.marker, t);
  if (!pose.present) return std::nullopt;
  return Eigen::Vector3d(pose.x, pose.y, pose.z + tag.height);
}

double Scene::tag_travelled(std::size_t index, double t0, double t1) const {
  // The path's length, summed over 1 ms steps (the trajectories are smooth at that scale).
  const int steps = std::max(1, static_cast<int>(std::ceil((t1 - t0) / 1e-3)));
  double length = 0;
  std::optional<Eigen::Vector3d> last = tag_position(index, t0);
  for (int k = 1; k <= steps; ++k) {
    const auto here = tag_position(index, t0 + (t1 - t0) * k / steps);
    if (last && here) length += (*here - *last).norm();
    last = here;
  }
  return length;
}

std::vector<SimRange> Scene::fire_tag(std::size_t index, double t, std::mt19937_64& rng) const {
  std::vector<SimRange> out;
  const auto here = tag_position(index, t);
  if (!here) return out;
  std::normal_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const auto nlos = [&](const Eigen::Vector3d& other) {
    double b = 0;
    for (const NlosZone& z : nlos_zones)
      if (crosses(z, *here, other)) b += z.bias;
    return b;
  };
  for (const SceneAnchor& a : anchors) {
    const double d = (a.position - *here).norm();
    // Drawn for every anchor, in range or not: one anchor's dropout does not shift the others' noise.
    const double noise = unit(rng), drop = uniform(rng);
    if (d > a.max_range || drop < a.dropout) continue;
    out.push_back(
        {a.id, false, std::max(0.0, d + a.bias + nlos(a.position) + a.sigma * noise), a.sigma, d, a.position});
  }
  if (tags[index].range_tags)
    for (std::size_t j = 0; j < tags.size(); ++j) {
      if (j == index) continue;
      const double noise = unit(rng);
      const auto there = tag_position(j, t);
      if (!there) continue;
      const double d = (*there - *here).norm();
      if (d > tags[index].max_range) continue;
      out.push_back({tags[j].id, true, std::max(0.0, d + nlos(*there) + tags[index].sigma * noise), tags[index].sigma,
                     d, *there});
    }
  return out;
}

}  // namespace ips::sim
