// Rigid bodies: named sets of markers fixed on one robot (a marker cube whose faces carry one
// id, markers along a robot). The body frame: x forward, y left, z up; a ground robot's origin
// lies on the floor (z = 0), so only its x, y and yaw are unknown.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace YAML {
class Node;
}

namespace ips {

/// One marker on a body.
struct BodyMarker {
  int id = -1;
  double edge = 0.0;   ///< black-square edge length, metres
  double plate = 0.0;  ///< side of the printed plate / cube face carrying it (>= edge), metres
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< centre of the square, body frame
  /// Columns: the marker's x axis (right as printed), y axis (up as printed) and the face
  /// normal (out of the printed side), in the body frame. Right-handed.
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
};

struct BodyDef {
  std::string name;
  std::vector<BodyMarker> markers;
  /// True: a ground robot (origin on the floor, upright): position from the known heights of
  /// its markers, yaw only. False: full 6-DoF pose from the markers' PnP poses.
  bool ground = true;
};

/// The pose of a body in the world.
struct BodyPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< body origin, world, metres
  double yaw = 0.0;                                    ///< heading of the body x axis from world +x towards +y, radians
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  ///< body -> world rotation
};

/// Marker axes (columns x, y, normal) for a face with this normal (body frame), turned by
/// `roll` radians about the normal. The marker's "up" (y) is the body z projected onto the
/// face (a side face reads upright); a face whose normal is vertical gets x = body x (turned
/// by roll about the normal). Throws std::invalid_argument for a zero normal.
Eigen::Matrix3d face_axes(const Eigen::Vector3d& normal, double roll);

/// The five faces of a marker cube (top and four sides; the bottom sits on the robot): side
/// `size`, markers of edge `edge` centred on each face, the cube's bottom `height` above the
/// body origin, centred on the body's z axis, faces aligned with the body axes.
std::vector<BodyMarker> cube_markers(int id, double edge, double size, double height);

/// A flat, face-up marker at `offset` (body frame centre) turned by `yaw` about z.
BodyMarker flat_marker(int id, double edge, const Eigen::Vector3d& offset, double yaw);

/// Why two markers of a body cannot both be there, or "" if fine: same plane and their plates
/// overlap (or the same centre).
std::string marker_overlap(const BodyMarker& a, const BodyMarker& b);

/// Classes of a marker face by its normal in the world (ground robots): up (a top face or a
/// flat marker), side (horizontal normal), or neither.
enum class FaceClass { kUp, kSide, kOther };
/// `tolerance`: radians the normal may be off vertical (up) or off horizontal (side).
FaceClass face_class(const Eigen::Vector3d& normal, double tolerance);
const char* face_class_name(FaceClass c);

/// Reports a problem in a body definition: the node, the full key path, what is wrong. Must
/// throw (ips::InputError with the file and line, as the caller's reader does).
using BodyFail = std::function<void(const YAML::Node& at, const std::string& key, const std::string& what)>;

/// Parses one body mapping (`name`, `ground`, `edge`, `cube: {id, edge, size, height}`,
/// `flat: [{id, offset: [x, y(, z)], edge, yaw_deg}]`, `markers: [{id, edge, plate, position:
/// [x, y, z], normal: [x, y, z], roll_deg}]`) except the keys listed in `extra_keys` (which
/// the caller reads: the simulator's pose and trajectory). Checks the markers of the body
/// (positive sizes, overlapping faces); `key` is the body's key path ("bodies[0]").
BodyDef parse_body(const YAML::Node& node, const std::string& key, const std::vector<std::string>& extra_keys,
                   const BodyFail& fail);

/// Checks a list of bodies against each other: unique names, no marker id used by two
/// bodies. Calls `fail(node_of_body_i, key, what)` through `at(i)`.
void check_bodies(const std::vector<BodyDef>& bodies, const std::vector<YAML::Node>& nodes, const std::string& list_key,
                  const BodyFail& fail);

}  // namespace ips
