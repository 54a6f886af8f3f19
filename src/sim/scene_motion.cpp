// Where a scene's markers and bodies are at time t: their trajectories (circle, line back and
// forth, waypoints with pauses, placements switched by a control file) and a body marker's pose
// from its body's. Scene::load (scene.cpp) reads what these evaluate.
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "ips/sim/scene.h"

namespace ips::sim {
namespace {

// Position and direction of travel at arc length s along a closed polyline.
void along_polyline(const std::vector<Eigen::Vector2d>& pts, double s, Eigen::Vector2d& pos, Eigen::Vector2d& dir) {
  double total = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) total += (pts[(i + 1) % pts.size()] - pts[i]).norm();
  s = std::fmod(s, total);
  if (s < 0) s += total;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector2d a = pts[i];
    const Eigen::Vector2d b = pts[(i + 1) % pts.size()];
    const double len = (b - a).norm();
    if (s <= len || i + 1 == pts.size()) {
      dir = len > 0 ? Eigen::Vector2d((b - a) / len) : Eigen::Vector2d(1, 0);
      pos = a + dir * std::min(s, len);
      return;
    }
    s -= len;
  }
}

// Arc length travelled at time t along a closed polyline at `speed`, stopping `pause`
// seconds at every point (the first pause at t = 0 at points[0]).
double arc_with_pauses(const std::vector<Eigen::Vector2d>& pts, double speed, double pause, double t) {
  if (!(speed > 0)) return 0.0;
  double total = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) total += (pts[(i + 1) % pts.size()] - pts[i]).norm();
  const double cycle = total / speed + pause * static_cast<double>(pts.size());
  t = std::fmod(t, cycle);
  if (t < 0) t += cycle;
  double s = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (t < pause) return s;
    t -= pause;
    const double len = (pts[(i + 1) % pts.size()] - pts[i]).norm();
    if (t < len / speed) return s + speed * t;
    t -= len / speed;
    s += len;
  }
  return s;
}

// The index a placements control file holds, or -1 (missing, empty, not a whole number).
long read_index(const std::filesystem::path& control) {
  std::ifstream in(control);
  long index = -1;
  std::string rest;
  if (!(in >> index) || (in >> rest)) return -1;
  return index;
}

// Pose at time t of something that starts at `start` and follows `tr` (markers and bodies).
MarkerPose pose_on_trajectory(const MarkerPose& start, const Trajectory& tr, double t) {
  MarkerPose pose = start;
  Eigen::Vector2d pos(pose.x, pose.y);
  Eigen::Vector2d dir(1, 0);
  const double s = tr.speed * t;
  switch (tr.kind) {
    case Trajectory::Kind::kStatic: return pose;
    case Trajectory::Kind::kCircle: {
      const double sign = tr.clockwise ? -1.0 : 1.0;
      const double a = tr.start_angle + sign * s / tr.radius;
      pos = tr.center + tr.radius * Eigen::Vector2d(std::cos(a), std::sin(a));
      dir = sign * Eigen::Vector2d(-std::sin(a), std::cos(a));
      break;
    }
    case Trajectory::Kind::kLine:
      // Back and forth: the closed polyline from -> to -> from.
      along_polyline(tr.points, s, pos, dir);
      break;
    case Trajectory::Kind::kWaypoints:
      along_polyline(tr.points, tr.pause > 0 ? arc_with_pauses(tr.points, tr.speed, tr.pause, t) : s, pos, dir);
      break;
    case Trajectory::Kind::kPlacements: {
      const long placed = read_index(tr.control);
      if (placed < 0 || placed >= static_cast<long>(tr.placements.size())) {
        pose.present = false;
        return pose;
      }
      return tr.placements[static_cast<std::size_t>(placed)];
    }
  }
  pose.x = pos.x();
  pose.y = pos.y();
  if (tr.heading_follows_path) pose.yaw = start.yaw + std::atan2(dir.y(), dir.x());
  return pose;
}

}  // namespace

Eigen::Matrix3d MarkerPose::frame() const {
  if (tilted) return axes;
  const double c = std::cos(yaw), s = std::sin(yaw);
  Eigen::Matrix3d m;
  m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}

MarkerPose Scene::marker_pose_at(std::size_t index, double t) const {
  const SceneMarker& m = markers.at(index);
  if (m.body < 0) return pose_on_trajectory(m.start, m.trajectory, t);
  // A body's marker: the body's pose applied to the marker's place on it.
  const BodyPose b = body_pose_at(static_cast<std::size_t>(m.body), t);
  const Eigen::Matrix3d R = b.q.toRotationMatrix();
  MarkerPose pose;
  const Eigen::Vector3d c = b.position + R * m.on_body.position;
  pose.x = c.x();
  pose.y = c.y();
  pose.z = c.z();
  pose.tilted = true;
  pose.axes = R * m.on_body.axes;
  pose.yaw = std::atan2(pose.axes(1, 0), pose.axes(0, 0));
  return pose;
}

BodyPose Scene::body_pose_at(std::size_t index, double t) const {
  const SceneBody& b = bodies.at(index);
  const MarkerPose p = pose_on_trajectory(b.start, b.trajectory, t);
  BodyPose out;
  out.position = {p.x, p.y, p.z};
  out.yaw = std::atan2(std::sin(p.yaw), std::cos(p.yaw));
  out.q = Eigen::AngleAxisd(p.yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(b.pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(b.roll, Eigen::Vector3d::UnitX());
  return out;
}

MarkerPose Scene::carrier_pose_at(std::size_t index, double t) const {
  const SceneCamera& c = cameras.at(index);
  if (!c.rides) {
    MarkerPose p;
    p.x = c.position.x();
    p.y = c.position.y();
    p.z = c.position.z();
    p.yaw = std::atan2(c.R_wc(1, 0), c.R_wc(0, 0));
    return p;
  }
  MarkerPose p = pose_on_trajectory(c.carrier_start, c.carrier, t);
  p.z = c.position.z();
  p.yaw = std::atan2(std::sin(p.yaw), std::cos(p.yaw));
  return p;
}

SceneCamera Scene::camera_at(std::size_t index, double t) const {
  SceneCamera c = cameras.at(index);
  if (!c.rides) return c;
  const MarkerPose p = carrier_pose_at(index, t);
  c.position = {p.x, p.y, p.z};
  c.R_wc = Eigen::AngleAxisd(p.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * c.R_mount;
  return c;
}

MarkerPose Scene::marker_pose(int id, double t) const {
  for (std::size_t i = 0; i < markers.size(); ++i) {
    if (markers[i].id == id) return marker_pose_at(i, t);
  }
  throw std::out_of_range("scene has no marker with id " + std::to_string(id));
}

}  // namespace ips::sim
