#pragma once
// One tag followed from its ranges one at a time: an extended Kalman filter over the tag's
// position and velocity (constant velocity, white-noise acceleration) and, optionally, each
// fixed anchor's range bias, updated by every range at the time it was measured.
//
// Why not a fix per firing: real UWB systems (DW1000 two-way ranging, the STAR-loc dataset)
// range one anchor at a time, ~8 ms apart, while the robot moves; a snapshot over a window of
// the latest range per anchor mixes positions, needs >= 4 ranges to say anything, and treats a
// module's constant bias as noise. The filter takes a range as soon as it is measured, weighs
// it by the geometry it adds, learns the biases the anchors keep, and leaves out a range that
// contradicts the track by more than the gate (non-line-of-sight: a positive excess).
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "ips/ranging/multilateration.h"

namespace ips {

struct RangeTrackerOptions {
  /// Spectral density of the white-noise acceleration (m^2/s^3): how hard the tag may
  /// accelerate between ranges. 0.3 is ~0.5 m/s^2 sustained for a second: lab robots, a rig
  /// carried by hand. Lower smooths more and lags more in a turn.
  double process_noise = 0.3;
  /// A range whose innovation exceeds this many of its predicted sigmas is left out (counted);
  /// 0 = every range is used.
  double gate_sigmas = 4.0;
  /// Each fixed anchor's range bias as a state (prior 1-sigma bias_sigma_m, drifting by
  /// bias_drift m/sqrt(s)); mobile references (other robots) carry none. From ranges alone a
  /// bias is only told apart from the tag's position by geometry that changes as the tag moves
  /// among many anchors: with 4 anchors and a small loop it is not (measured: 10 Hz firings of
  /// 1 cm ranges on a 0.45 m circle, 60 s: learnt biases wander +-1 cm, p95 32 mm against 19 mm
  /// without them). kAuto learns them where that is well posed: with >= 3 anchors more than
  /// the unknowns (5 at a known height, 6 in 3-D), or once the tag's position is given another
  /// way (add_position: the cameras). Until then the biases stay at 0.
  enum class BiasLearning { kOff, kOn, kAuto };
  BiasLearning bias_learning = BiasLearning::kAuto;
  double bias_sigma_m = 0.03;
  double bias_drift = 0.001;
  /// The tag's known height (a ground robot): the filter follows x, y only.
  std::optional<double> known_height;
  /// Otherwise, the heights the tag can be at (its first fix uses it; see RangeSolveOptions).
  std::optional<std::pair<double, double>> z_range;
  /// The first fix takes the latest range to each reference within this span (s)...
  double init_window_s = 0.2;
  /// ...and after this many ranges in a row left out by the gate the track starts over from a
  /// new fix (it has lost the tag, or learnt a wrong bias).
  int restart_after_rejections = 10;
  /// A gap this long without an accepted range (s) also starts the track over.
  double max_gap_s = 2.0;
  /// A range up to this much older than the newest (s) is applied in its place and the newer
  /// ones applied again after it (radio bursts, a bridge that batches); older ones are left out.
  double reorder_window_s = 0.5;

  bool operator==(const RangeTrackerOptions&) const = default;
};

/// What one range did to the track.
enum class RangeUpdate {
  kInitialising,  ///< kept for the first fix: too few references yet
  kStarted,       ///< completed the first fix (or a restart's): the track now has a state
  kAccepted,      ///< used by the filter
  kRejected,      ///< left out by the gate (non-line-of-sight, or a wrong anchor)
  kOutOfOrder,    ///< older than the reorder window (or than the track's start): left out
  kInvalid,       ///< not a finite, positive range with a positive sigma
  kUnused,        ///< a speed the track could not use: not started, or no direction to apply it along
};
const char* range_update_word(RangeUpdate update);  // initialising, started, accepted, ...

struct RangeTrackState {
  std::int64_t t_ns = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of position, m^2 (z row/column 0 at a known height)
};

class RangeTracker {
 public:
  /// `anchors`: the fixed references this tag may range to, by index (a bias state each when
  /// bias_learning is not kOff).
  RangeTracker(std::vector<Eigen::Vector3d> anchors, RangeTrackerOptions options);

  /// A range to fixed anchor `anchor` (an index into the constructor's list) measured at t_ns.
  RangeUpdate add_anchor_range(std::int64_t t_ns, std::size_t anchor, double range_m, double sigma_m);
  /// A range to a reference that moves (another robot): its position at t_ns and that
  /// position's 1-sigma (isotropic, added to the range's in quadrature).
  RangeUpdate add_mobile_range(std::int64_t t_ns, const Eigen::Vector3d& reference, double reference_sigma_m,
                               double range_m, double sigma_m);

  /// The tag's position seen another way at t_ns (the cameras, where they see its robot), with
  /// its covariance (m^2): a position update. With bias states this is what calibrates the
  /// anchors: ranges from a known position say exactly how long each anchor reads. It also
  /// starts a track that has none yet. Not gated (the cameras are the reference).
  RangeUpdate add_position(std::int64_t t_ns, const Eigen::Vector3d& position, const Eigen::Matrix3d& covariance);

  /// The tag's speed at t_ns (m/s) with its 1-sigma: odometry's distance travelled since the
  /// previous firing over the time between them. A scalar update of |velocity| along the
  /// track's own direction of travel, gated like a range; a speed within 2 sigma of zero is
  /// standing still (velocity 0 on every axis, sigma + the speed itself). kUnused before the
  /// track starts, or when it has no direction yet (|velocity| < 1 mm/s) for a moving tag.
  RangeUpdate add_speed(std::int64_t t_ns, double speed_mps, double sigma_mps);

  bool started() const { return started_; }
  /// The state at the last range (nullopt before the first fix).
  std::optional<RangeTrackState> state() const;
  /// The state predicted to t_ns (>= the last range's time), covariance grown by the process noise.
  std::optional<RangeTrackState> predict(std::int64_t t_ns) const;
  /// The state at t_ns from the ranges up to t_ns (within the reorder window; later: predict).
  std::optional<RangeTrackState> state_at(std::int64_t t_ns) const;
  /// Each fixed anchor's estimated bias (m; zeros while not learnt).
  std::vector<double> biases() const;

  std::uint64_t accepted() const { return accepted_; }
  std::uint64_t rejected() const { return rejected_; }
  std::uint64_t restarts() const { return restarts_; }
  std::uint64_t replayed() const { return replayed_; }    ///< late ranges applied in their place
  std::uint64_t positions() const { return positions_; }  ///< add_position updates used
  std::uint64_t speeds() const { return speeds_; }        ///< add_speed updates used
  bool learning_bias() const { return has_bias_ && !bias_locked_; }

 private:
  enum class Kind { kRange, kPosition, kSpeed };
  struct Pending {
    std::int64_t t_ns;
    int anchor;                 // -1: mobile
    Eigen::Vector3d reference;  // the reference's position, or the position measured (kPosition)
    double range_m, sigma_m;    // kSpeed: the speed and its sigma, m/s
    Kind kind = Kind::kRange;
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // kPosition: of the position
  };
  struct Snapshot {
    std::int64_t t_ns = 0;
    Eigen::VectorXd x;
    Eigen::MatrixXd p;
    int rejections = 0;
  };
  struct Applied {  // a range of the reorder window and the state right after it
    Pending range;
    Snapshot after;
  };
  RangeUpdate add(const Pending& range);
  RangeUpdate apply(const Pending& range);
  RangeUpdate collect(const Pending& range);
  RangeUpdate update_position(const Pending& position, const Eigen::VectorXd& x, const Eigen::MatrixXd& p);
  RangeUpdate update_speed(const Pending& speed, const Eigen::VectorXd& x, const Eigen::MatrixXd& p);
  /// A linear update of the rows `h` of the state by z (covariance r), Joseph form.
  void update_linear(const Eigen::MatrixXd& h, const Eigen::VectorXd& z, const Eigen::MatrixXd& r,
                     const Eigen::VectorXd& x, const Eigen::MatrixXd& p);
  RangeUpdate start_at(const Pending& position);
  void start(std::int64_t t_ns, const Eigen::Vector3d& position, const Eigen::MatrixXd& covariance);
  void propagate(std::int64_t from_ns, std::int64_t to_ns, Eigen::VectorXd& x, Eigen::MatrixXd& p) const;
  Snapshot snapshot() const;
  void restore(const Snapshot& s);
  void remember(const Pending& range);
  RangeTrackState state_from(const Snapshot& from, std::int64_t t_ns) const;
  int dims() const { return options_.known_height ? 2 : 3; }
  void unlock_bias();

  std::vector<Eigen::Vector3d> anchors_;
  RangeTrackerOptions options_;
  bool started_ = false;
  bool has_bias_ = false;     // bias states exist (bias_learning != kOff)
  bool bias_locked_ = false;  // kAuto, not yet well posed: the biases' variance held at 0
  std::int64_t t_ns_ = 0;
  Eigen::VectorXd x_;  // position (dims), velocity (dims), a bias per anchor when estimated
  Eigen::MatrixXd p_;
  std::vector<Pending> pending_;  // ranges kept for the first fix
  int rejections_in_a_row_ = 0;
  Snapshot base_;                // the state before the reorder window's oldest range
  std::deque<Applied> history_;  // the reorder window, oldest first
  bool replaying_ = false;       // applying newer ranges again: not counted twice
  std::uint64_t accepted_ = 0, rejected_ = 0, restarts_ = 0, replayed_ = 0, positions_ = 0, speeds_ = 0;
};

}  // namespace ips
