// The `ranging:` section of ipsd's configuration (docs/ranging.md): where the range input
// listens, who may send, the anchors the tags range to, which marker each tag belongs to, and
// how a firing's ranges are solved. Absent = no range input.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include <Eigen/Core>

#include "ips/input/range_admission.h"
#include "ips/ranging/range_tracker.h"

namespace ips {

/// A fixed anchor. A measured range is corrected as (range - bias) / scale before solving: a
/// module that reads 3 cm long has bias 0.03; one whose clock runs 0.1 % fast, scale 1.001.
struct RangingAnchor {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< world frame, m
  double bias_m = 0.0;
  double scale = 1.0;
  double sigma_m = 0.0;  ///< this anchor's range 1-sigma when the firing says 0; 0 = ranging.sigma

  bool operator==(const RangingAnchor&) const = default;
};

/// What carries a tag: a marker (the tag `height` above its centre; its fixes, that much lower,
/// are published as that marker) or a rigid body (its fixes place the body: the body's origin
/// is the tag minus the tag's offset turned by the body's last known orientation).
struct RangingTag {
  int marker = -1;                                   ///< >= 0: the marker id; -1: on `body`
  std::string body;                                  ///< config bodies[].name when marker < 0
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< the tag in the body's frame, m
  double height = 0.0;                               ///< on a marker: the tag this far above the marker's centre, m

  static RangingTag on_marker(int id) {
    RangingTag t;
    t.marker = id;
    return t;
  }
  bool on_body() const { return marker < 0; }
  bool operator==(const RangingTag&) const = default;
};

struct RangingConfig {
  /// address, port (0 = the section is absent: no range input), allow, psk, limits; its
  /// tags and anchors are filled from the ones below.
  RangeInputSettings input;
  std::map<std::uint32_t, RangingAnchor> anchors;
  std::map<std::uint32_t, RangingTag> tags;          ///< tag id -> what carries it
  std::string method = "robust";                     ///< ips::range_method_names()
  std::optional<double> height;                      ///< the tags' known height (robots on a floor), m
  std::optional<std::pair<double, double>> z_range;  ///< otherwise, the heights they can be at
  double sigma_m = 0.05;                             ///< a range's 1-sigma when neither firing nor anchor says
  /// Ultrasound (ranging.ultrasound): every range is first multiplied by
  /// speed_of_sound(temperature) / assumed_speed (ips/ranging/speed_of_sound.h), then the
  /// anchor's bias and scale are undone. Absent: ranges are used as sent (UWB: radio).
  std::optional<double> temperature_c;
  double assumed_speed_of_sound = 343.0;  ///< m/s the senders' modules convert time of flight with
  /// ranging.track: each tag followed by a RangeTracker fed every range at its firing time (a
  /// firing of one range is enough, anchor biases are learnt, non-line-of-sight ranges gated);
  /// false: each firing solved alone by `method`, which then needs >= 4 ranges (3 at a height).
  /// The tracker's known_height / z_range are `height` / `z_range` above.
  bool track = true;
  RangeTrackerOptions track_options;
  /// ranging.track.camera_reference: where the cameras see a tag's own robot, their position
  /// is a measurement of its track. The ranges measured meanwhile then calibrate each anchor's
  /// bias against the cameras, and a robot that leaves the cameras' view is handed over from
  /// their position, not from a track of its own.
  bool track_camera_reference = true;
  /// ranging.track.mutual: a range from one tag to another is a measurement of both: it also
  /// updates the other tag's track, with the firing tag's state (and its covariance along the
  /// line between them) as the reference, where the cameras do not place the other's robot.
  /// One update of the pair's joint filter, their tracks taken as independent at that instant.
  bool track_mutual = true;

  bool enabled() const { return input.port != 0; }
  bool operator==(const RangingConfig&) const = default;
};

}  // namespace ips
