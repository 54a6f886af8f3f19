// Body geometry: face frames, the marker cube, the overlap check.
#include <cmath>
#include <stdexcept>

#include "ips/body/body.h"

namespace ips {

Eigen::Matrix3d face_axes(const Eigen::Vector3d& normal, double roll) {
  if (!(normal.norm() > 1e-9) || !normal.allFinite()) throw std::invalid_argument("face normal is zero");
  const Eigen::Vector3d n = normal.normalized();
  Eigen::Vector3d y;
  // Up on the face: body z projected onto the face; a horizontal face (normal vertical) takes
  // body y as up, so that its x is body x (for a face-up marker).
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  if (std::abs(n.z()) > 1.0 - 1e-9) {
    y = Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(n) * n;
    if (n.z() < 0) y = -y;  // face-down: keep x along body x
  } else {
    y = z - z.dot(n) * n;
  }
  y.normalize();
  Eigen::Vector3d x = y.cross(n);
  // Turn the marker in its plane by roll (counter-clockwise seen from the front).
  const double c = std::cos(roll), s = std::sin(roll);
  const Eigen::Vector3d xr = c * x + s * y;
  const Eigen::Vector3d yr = -s * x + c * y;
  Eigen::Matrix3d axes;
  axes.col(0) = xr;
  axes.col(1) = yr;
  axes.col(2) = n;
  return axes;
}

std::vector<BodyMarker> cube_markers(int id, double edge, double size, double height) {
  const double h = size / 2.0;
  const Eigen::Vector3d centre(0, 0, height + h);
  const Eigen::Vector3d normals[5] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                      -Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitY()};
  std::vector<BodyMarker> out;
  for (const auto& n : normals) {
    BodyMarker m;
    m.id = id;
    m.edge = edge;
    m.plate = size;
    m.position = centre + h * n;
    m.axes = face_axes(n, 0.0);
    out.push_back(m);
  }
  return out;
}

BodyMarker flat_marker(int id, double edge, const Eigen::Vector3d& offset, double yaw) {
  BodyMarker m;
  m.id = id;
  m.edge = edge;
  m.plate = edge;
  m.position = offset;
  m.axes = face_axes(Eigen::Vector3d::UnitZ(), yaw);
  return m;
}

std::string marker_overlap(const BodyMarker& a, const BodyMarker& b) {
  const double pa = std::max(a.plate, a.edge), pb = std::max(b.plate, b.edge);
  if ((a.position - b.position).norm() < 1e-3) return "same centre";
  const Eigen::Vector3d na = a.axes.col(2), nb = b.axes.col(2);
  // Faces on different planes (or back to back) do not cover each other.
  if (na.dot(nb) < 1.0 - 1e-6 || std::abs(na.dot(b.position - a.position)) > 1e-3) return "";
  // Same plane: separating-axis test of the two squares in the plane.
  const Eigen::Vector3d axes[4] = {a.axes.col(0), a.axes.col(1), b.axes.col(0), b.axes.col(1)};
  for (const auto& ax : axes) {
    auto extent = [&](const BodyMarker& m, double side) {
      const double c = ax.dot(m.position);
      const double r = side / 2.0 * (std::abs(ax.dot(m.axes.col(0))) + std::abs(ax.dot(m.axes.col(1))));
      return std::pair<double, double>(c - r, c + r);
    };
    const auto ea = extent(a, pa), eb = extent(b, pb);
    if (ea.second <= eb.first + 1e-9 || eb.second <= ea.first + 1e-9) return "";
  }
  return "overlapping faces in one plane";
}

FaceClass face_class(const Eigen::Vector3d& normal, double tolerance) {
  const Eigen::Vector3d n = normal.normalized();
  if (n.z() > std::cos(tolerance)) return FaceClass::kUp;
  if (std::abs(n.z()) < std::sin(tolerance)) return FaceClass::kSide;
  return FaceClass::kOther;
}

const char* face_class_name(FaceClass c) {
  switch (c) {
    case FaceClass::kUp: return "up";
    case FaceClass::kSide: return "side";
    case FaceClass::kOther: break;
  }
  return "other";
}

}  // namespace ips
