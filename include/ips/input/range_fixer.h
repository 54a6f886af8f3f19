// A firing taken by the range input -> a world observation for fusion: its ranges corrected by
// each anchor's bias and scale, then either fed one by one to the tag's range tracker
// (ranging.track, the default) or solved together by the configured method, and published as
// the tag's marker. Firings that give no position are counted by the reason's word.
// Not thread-safe: owned by the range input's receive thread (counters() under the caller's lock).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ips/core/observation.h"
#include "ips/input/anchor_survey.h"
#include "ips/input/range_admission.h"
#include "ips/input/ranging_settings.h"
#include "ips/ranging/range_tracker.h"

namespace ips {

struct RangeFixCounters {
  std::uint64_t fixes = 0;                      ///< firings solved and handed to fusion
  std::map<std::string, std::uint64_t> failed;  ///< firings not solved, by range_fix_status_word
  std::uint64_t mobile_references = 0;          ///< ranges to another tag used, its robot as a mobile anchor
  /// Ranges to another tag left out: its robot has no published position within
  /// RangeFixer::kMobileReferenceAge of the firing.
  std::uint64_t mobile_references_unknown = 0;
  /// ranging.track.mutual: ranges to another tag also applied to that tag's own track (its
  /// robot not placed by the cameras), by what they did there (range_update_word).
  std::map<std::string, std::uint64_t> mutual;
  /// ranging.track: what each range did to its tag's track, by range_update_word (accepted,
  /// rejected, initialising, started, out_of_order, invalid).
  std::map<std::string, std::uint64_t> ranges;
  /// ranging.track.camera_reference: camera-seen states of a tag's own robot used by its track.
  std::uint64_t camera_references = 0;
  /// Firings with odometry, by what it did: with ranging.track a speed update of the track
  /// (range_update_word: accepted, rejected, unused); solved per firing, `sphere` (a range to
  /// the tag's previous fix); `no_previous` when the tag's previous firing was not received
  /// (the distance then spans an unknown time).
  std::map<std::string, std::uint64_t> odometry;
};

/// A tag's track as the status shows it.
struct RangeTrackSummary {
  std::uint32_t tag = 0;
  bool started = false;
  std::uint64_t restarts = 0;
  std::uint64_t replayed = 0;                ///< late ranges applied in their place
  bool learning_bias = false;                ///< its anchor biases are being learnt (ranging.track.learn_bias)
  std::map<std::uint32_t, double> biases_m;  ///< learnt per anchor, beyond the configured bias
};

/// A robot's latest published state, where another robot's tag ranges to it.
struct MobileReference {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();    ///< m/s; zero when not known
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of position, m^2
  std::int64_t t_mono_ns = 0;
  bool seen_by_cameras = false;  ///< the cameras placed this state (not ranges alone)
};

/// The state of a point fixed on a rigid body (a tag at `offset` in the body's frame) from the
/// body origin's state `origin`, its orientation (body -> world) and its yaw rate (rad/s about
/// world z; 0 when not measured): the origin plus the turned offset, moving with the origin's
/// velocity plus the turn's share at the offset. Covariance, time and camera flag as the origin's.
MobileReference point_on_body(const MobileReference& origin, const Eigen::Quaterniond& orientation, double yaw_rate,
                              const Eigen::Vector3d& offset);

/// Where `tag` is, from its carrier's published state: a marker's (`orientation`, `yaw_rate`
/// unused) raised by the tag's height, or a body origin's through point_on_body with the tag's
/// offset.
MobileReference tag_point(const MobileReference& carrier, const Eigen::Quaterniond& orientation, double yaw_rate,
                          const RangingTag& tag);

class RangeFixer {
 public:
  /// The latest published state of the tag itself, if any (the daemon's fused stream): its
  /// marker's state, or its body's turned and moved to where the tag sits on the body.
  using StateOf = std::function<std::optional<MobileReference>(const RangingTag& tag)>;
  /// A mobile reference's state is used this long before or after the firing, moved to the
  /// firing time by its velocity (a camera's state is 100-300 ms old when a firing arrives on
  /// a busy machine); older, the range to it is left out. The move's own uncertainty, half an
  /// unknown 1 m/s^2 times the age squared, is added to the range's.
  static constexpr std::int64_t kMobileReferenceAge = 500'000'000;
  /// ranging.track.camera_reference: a camera-placed state of the tag's own robot at most this
  /// far from the firing is fed to its track (within the track's reorder window).
  static constexpr std::int64_t kCameraReferenceAge = 300'000'000;

  explicit RangeFixer(RangingConfig config, StateOf state_of = {});

  /// The observation of `firing`'s tag at its firing time (marker id = the tag's marker, the
  /// position lowered by the tag's height to the marker's centre; -1 for a tag on a body: the
  /// position is the tag's, the caller places the body, see RangingTag), or nullopt (counted) if it cannot
  /// be solved. `t_real_ns` is the firing time on this host's CLOCK_REALTIME. A range to
  /// another tag uses that tag's robot, as published, as an anchor: its position's variance
  /// (the mean over the axes) is added to the range's. A firing's odometry (the distance
  /// travelled since the tag's previous firing, if that firing was received) is, with
  /// ranging.track, the tag's speed over the time between them; solved per firing, a range to
  /// the previous firing's fix (Albayati & Kurt's "own last position and distance travelled").
  std::optional<WorldObservation> fix(const AdmittedFiring& firing, std::int64_t t_real_ns);

  const RangeFixCounters& counters() const { return counters_; }
  const RangingConfig& config() const { return config_; }
  /// Every tag's track so far (ranging.track), by tag id.
  std::vector<RangeTrackSummary> tracks() const;
  /// ranging.track.camera_reference: each anchor as the ranges taken where the cameras placed
  /// the tag's robot (within kSurveyAge of the firing) see it (ips/input/anchor_survey.h).
  std::vector<AnchorSurvey> anchor_surveys() const { return surveyor_.surveys(); }
  /// (Camera frames reach fusion after a firing of the same instant: the state at hand is
  /// 100-300 ms older than the firing; it is moved to the firing time by its velocity.)
  static constexpr std::int64_t kSurveyAge = kCameraReferenceAge;
  /// The anchor survey's verdicts that changed since the last call (for the log).
  std::vector<AnchorEvent> take_anchor_events() { return std::exchange(anchor_events_, {}); }

 private:
  /// One range of a firing, corrected and with its reference placed.
  struct Corrected {
    bool mobile = false;
    std::uint32_t other_tag = 0;     // mobile: the tag ranged to
    bool reference_known = true;     // mobile: its robot's state was at hand (else: only the mutual use)
    bool placed_by_cameras = false;  // mobile: that state is the cameras', within kCameraReferenceAge
    std::size_t anchor = 0;          // index into anchor_ids_ (fixed anchors)
    Eigen::Vector3d reference = Eigen::Vector3d::Zero();
    double range_m = 0, sigma_m = 0;
    double reference_sigma_m = 0;  // mobile: the reference's own position uncertainty
  };
  std::vector<Corrected> correct(const AdmittedFiring& firing);
  std::optional<WorldObservation> solve(const std::vector<Corrected>& ranges, const AdmittedFiring& firing,
                                        const RangingTag& tag, std::int64_t t_real_ns);
  std::optional<WorldObservation> track(const std::vector<Corrected>& ranges, const AdmittedFiring& firing,
                                        const RangingTag& tag, std::int64_t t_real_ns);
  /// ranging.track.mutual: the range `c` from the firing tag (its track's state `from` just
  /// before this firing) to another tag, applied to that tag's track too.
  void share_range(const Corrected& c, const RangeTrackState& from, std::int64_t t_ns);
  RangeTracker& tracker_of(std::uint32_t tag);

  RangingConfig config_;
  StateOf state_of_;
  RangeFixCounters counters_;
  std::vector<std::uint32_t> anchor_ids_;  // the configured anchors in id order
  std::vector<Eigen::Vector3d> anchor_positions_;
  std::map<std::uint32_t, RangeTracker> trackers_;               // by tag
  std::map<std::uint32_t, std::int64_t> camera_reference_used_;  // by tag: the last camera state's time fed
  AnchorSurveyor surveyor_;
  std::vector<AnchorEvent> anchor_events_;
  void survey(const std::vector<Corrected>& ranges, const AdmittedFiring& firing, const RangingTag& tag);
  /// A tag's recent firings (by firing counter), for the odometry of the next one.
  struct PastFiring {
    std::int64_t t_ns = 0;
    std::optional<MobileReference> fix;  // the position it gave, if any
  };
  std::map<std::uint32_t, std::map<std::uint32_t, PastFiring>> past_firings_;  // by tag
  /// The firing before `firing` of the same tag, if received (and within the reorder window).
  const PastFiring* previous_firing(const AdmittedFiring& firing) const;
  void remember_firing(const AdmittedFiring& firing, const std::optional<WorldObservation>& fix);
  static double odometry_sigma(const RangeFiring& firing);
};

}  // namespace ips
