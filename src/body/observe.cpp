// One detected marker of one camera -> what it says about its body (see body_estimate.h).
//
// The marker's pose comes from IPPE in a virtual camera whose rays are the mapper's world rays
// (so a plane model's own correction is honoured). The pose decides which class of face was
// seen; for a ground robot the position and yaw then come from the known heights of the
// marker's corners on the body (each corner's ray meets the plane at its height: the same
// precise known-height path as flat markers), which does not suffer PnP's depth noise.
#include <cmath>
#include <numbers>

#include "angle.h"
#include "ips/body/body_estimate.h"

namespace ips {
namespace {

// Corners of the black square in marker units (x right, y up as printed), ArUco order.
constexpr double kCorners[4][2] = {{-0.5, 0.5}, {0.5, 0.5}, {0.5, -0.5}, {-0.5, -0.5}};

using body_detail::wrap;

}  // namespace

BodyEstimator::BodyEstimator(std::vector<BodyDef> bodies, BodyEstimatorOptions options)
    : bodies_(std::move(bodies)), options_(options), memory_(bodies_.size()) {
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    for (const auto& m : bodies_[b].markers) owner_.emplace(m.id, static_cast<int>(b));
}

int BodyEstimator::body_of(int id) const {
  const auto it = owner_.find(id);
  return it == owner_.end() ? -1 : it->second;
}

bool BodyEstimator::observe(const CameraObservation& obs, const Mapper& mapper, int camera_index,
                            std::int64_t t_mono_ns, std::int64_t t_real_ns, BodyObservation& out,
                            std::string* why) const {
  auto reject = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  const int b = body_of(obs.id);
  if (b < 0) return reject("not on a body");
  const BodyDef& body = bodies_[static_cast<std::size_t>(b)];
  CameraPose cam;
  if (!camera_pose_of(mapper, cam)) return reject("camera has no pose model");

  // World rays of the corners, and the corners in the virtual camera (R_wc, centre).
  std::array<Eigen::Vector3d, 4> ray;
  std::array<Point2, 4> virt;
  for (std::size_t i = 0; i < 4; ++i) {
    const Point2 n = obs.corners_norm[i];
    Eigen::Vector3d o;
    if (!mapper.world_ray({n.x, n.y, 1.0}, o, ray[i])) return reject("corner without a ray");
    const Eigen::Vector3d q = cam.R_wc.transpose() * ray[i];
    if (!(q.z() > 0)) return reject("corner behind the camera");
    virt[i] = {q.x() / q.z(), q.y() / q.z()};
  }
  std::vector<int> same_id;
  for (std::size_t k = 0; k < body.markers.size(); ++k)
    if (body.markers[k].id == obs.id) same_id.push_back(static_cast<int>(k));
  const double edge = body.markers[static_cast<std::size_t>(same_id.front())].edge;
  const auto sols = planar_marker_poses(virt, edge);
  if (sols.empty()) return reject("no marker pose");

  out = BodyObservation{};
  out.body = b;
  out.id = obs.id;
  out.camera_index = camera_index;
  out.area_px = obs.area_px;
  out.t_mono_ns = t_mono_ns;
  out.t_real_ns = t_real_ns;

  const double tol = options_.face_tolerance;
  if (!body.ground) {
    // Full pose: the best solution, unless the flip explains the corners nearly as well.
    if (sols.size() > 1 && sols[1].error < options_.ambiguity_ratio * sols[0].error &&
        (sols[0].R.col(2) - sols[1].R.col(2)).norm() > std::sin(tol))
      return reject("ambiguous view (two poses fit)");
    const Eigen::Matrix3d R_wm = cam.R_wc * sols[0].R;
    const Eigen::Vector3d p_wm = cam.centre + cam.R_wc * sols[0].t;
    out.marker_centre = p_wm;
    out.marker_normal = R_wm.col(2);
    for (int k : same_id) {
      const BodyMarker& m = body.markers[static_cast<std::size_t>(k)];
      const Eigen::Matrix3d R_wb = R_wm * m.axes.transpose();
      out.faces.push_back(k);
      out.qs.emplace_back(R_wb);
      out.yaws.push_back(std::atan2(R_wb(1, 0), R_wb(0, 0)));
      out.positions.push_back(p_wm - R_wb * m.position);
    }
    out.face = face_class(R_wm.col(2), tol);
    return true;
  }

  // Ground robot: the class of face seen, from the orientation of each PnP solution.
  auto class_of = [&](const MarkerPoseSolution& s) { return face_class(cam.R_wc * s.R.col(2), tol); };
  auto has_class = [&](FaceClass c) {
    for (int k : same_id)
      if (face_class(body.markers[static_cast<std::size_t>(k)].axes.col(2), tol) == c) return true;
    return false;
  };
  // Each corner's ray meets the horizontal plane at that corner's height on face m.
  auto corners_on = [&](const BodyMarker& m, std::array<Eigen::Vector3d, 4>& p) {
    bool ok = true;
    for (std::size_t i = 0; i < 4; ++i) {
      const Eigen::Vector3d on_body =
          m.position + m.edge * (kCorners[i][0] * m.axes.col(0) + kCorners[i][1] * m.axes.col(1));
      const double s = (on_body.z() - cam.centre.z()) / ray[i].z();
      ok = ok && s > 0 && std::isfinite(s);
      p[i] = cam.centre + s * ray[i];
    }
    return ok;
  };
  // How far those four points are from a square of the marker's edge (RMS over the four sides
  // and two diagonals, metres): the wrong face's heights bend them out of shape.
  auto shape_error = [&](FaceClass c) {
    for (int k : same_id) {
      const BodyMarker& m = body.markers[static_cast<std::size_t>(k)];
      if (face_class(m.axes.col(2), tol) != c) continue;
      std::array<Eigen::Vector3d, 4> p;
      if (!corners_on(m, p)) return 1e9;
      double sum = 0;
      for (std::size_t i = 0; i < 4; ++i) sum += std::pow((p[(i + 1) % 4] - p[i]).norm() - m.edge, 2);
      sum += std::pow((p[2] - p[0]).norm() - m.edge * std::numbers::sqrt2, 2);
      sum += std::pow((p[3] - p[1]).norm() - m.edge * std::numbers::sqrt2, 2);
      return std::sqrt(sum / 6.0);
    }
    return 1e9;
  };
  const FaceClass c0 = class_of(sols[0]);
  FaceClass chosen = c0;
  const bool close = sols.size() > 1 && sols[1].error < options_.ambiguity_ratio * sols[0].error;
  if (close) {
    const FaceClass c1 = class_of(sols[1]);
    const bool v0 = c0 != FaceClass::kOther && has_class(c0), v1 = c1 != FaceClass::kOther && has_class(c1);
    if (v0 && v1 && c0 != c1) {
      // Both poses fit the corners and each fits a face: the known heights of the two faces
      // decide, when one of them makes a square and the other clearly does not.
      const double e0 = shape_error(c0), e1 = shape_error(c1);
      if (e0 < options_.shape_ratio * e1) {
        chosen = c0;
      } else if (e1 < options_.shape_ratio * e0) {
        chosen = c1;
      } else {
        return reject("ambiguous view (two poses fit different faces)");
      }
    } else if (!v0 && !v1) {
      return reject("orientation fits no face of the body");
    } else {
      chosen = v0 ? c0 : c1;
    }
  } else if (c0 == FaceClass::kOther || !has_class(c0)) {
    return reject("orientation fits no face of the body");
  }
  const MarkerPoseSolution& used = (close && chosen != c0) ? sols[1] : sols[0];
  out.face = chosen;
  out.marker_normal = cam.R_wc * used.R.col(2);
  // The chosen face's corners must make the marker's square (a marker of another size or a
  // face the pose misjudged does not).
  if (shape_error(chosen) > options_.shape_tolerance * body.markers[static_cast<std::size_t>(same_id.front())].edge)
    return reject("corners do not fit the face at its height");

  for (int k : same_id) {
    const BodyMarker& m = body.markers[static_cast<std::size_t>(k)];
    if (face_class(m.axes.col(2), tol) != chosen) continue;
    std::array<Eigen::Vector3d, 4> p;
    if (!corners_on(m, p)) continue;
    const Eigen::Vector3d centre = (p[0] + p[1] + p[2] + p[3]) / 4.0;
    // The marker axis that runs most horizontally on the body gives the heading.
    const bool use_x = m.axes.col(0).head<2>().norm() >= m.axes.col(1).head<2>().norm();
    const Eigen::Vector3d axis_w =
        use_x ? Eigen::Vector3d((p[1] - p[0]) + (p[2] - p[3])) : Eigen::Vector3d((p[0] - p[3]) + (p[1] - p[2]));
    const Eigen::Vector3d axis_b = use_x ? Eigen::Vector3d(m.axes.col(0)) : Eigen::Vector3d(m.axes.col(1));
    const double yaw = wrap(std::atan2(axis_w.y(), axis_w.x()) - std::atan2(axis_b.y(), axis_b.x()));
    const Eigen::Matrix3d Rz = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    Eigen::Vector3d origin = centre - Rz * m.position;
    origin.z() = 0.0;  // a ground robot's origin is on the floor
    out.marker_centre = centre;
    out.faces.push_back(k);
    out.yaws.push_back(yaw);
    out.qs.emplace_back(Rz);
    out.positions.push_back(origin);
  }
  if (out.faces.empty()) return reject("corner rays miss the face heights");
  return true;
}

}  // namespace ips
