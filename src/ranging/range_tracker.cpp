#include "ips/ranging/range_tracker.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <Eigen/Cholesky>

namespace ips {

const char* range_update_word(RangeUpdate update) {
  switch (update) {
    case RangeUpdate::kInitialising: return "initialising";
    case RangeUpdate::kStarted: return "started";
    case RangeUpdate::kAccepted: return "accepted";
    case RangeUpdate::kRejected: return "rejected";
    case RangeUpdate::kOutOfOrder: return "out_of_order";
    case RangeUpdate::kInvalid: return "invalid";
    case RangeUpdate::kUnused: return "unused";
  }
  return "invalid";
}

RangeTracker::RangeTracker(std::vector<Eigen::Vector3d> anchors, RangeTrackerOptions options)
    : anchors_(std::move(anchors)), options_(std::move(options)) {
  const int d = dims();
  has_bias_ = options_.bias_learning != RangeTrackerOptions::BiasLearning::kOff && !anchors_.empty();
  bias_locked_ =
      options_.bias_learning == RangeTrackerOptions::BiasLearning::kAuto && static_cast<int>(anchors_.size()) < d + 3;
  const int nb = has_bias_ ? static_cast<int>(anchors_.size()) : 0;
  x_ = Eigen::VectorXd::Zero(2 * d + nb);
  p_ = Eigen::MatrixXd::Zero(2 * d + nb, 2 * d + nb);
  if (!bias_locked_)
    for (int k = 0; k < nb; ++k) p_(2 * d + k, 2 * d + k) = options_.bias_sigma_m * options_.bias_sigma_m;
}

void RangeTracker::unlock_bias() {
  // The tag's position is now known another way: bias and position can be told apart. The
  // biases (held at 0 so far, uncorrelated with the rest) get their prior.
  if (!has_bias_ || !bias_locked_) return;
  bias_locked_ = false;
  const int d = dims();
  for (int k = 2 * d; k < static_cast<int>(x_.size()); ++k) p_(k, k) = options_.bias_sigma_m * options_.bias_sigma_m;
}

RangeUpdate RangeTracker::add_anchor_range(std::int64_t t_ns, std::size_t anchor, double range_m, double sigma_m) {
  if (anchor >= anchors_.size()) return RangeUpdate::kInvalid;
  return add({t_ns, static_cast<int>(anchor), anchors_[anchor], range_m, sigma_m});
}

RangeUpdate RangeTracker::add_mobile_range(std::int64_t t_ns, const Eigen::Vector3d& reference,
                                           double reference_sigma_m, double range_m, double sigma_m) {
  if (!std::isfinite(reference_sigma_m) || reference_sigma_m < 0 || !reference.allFinite())
    return RangeUpdate::kInvalid;
  return add({t_ns, -1, reference, range_m, std::hypot(sigma_m, reference_sigma_m)});
}

void RangeTracker::propagate(std::int64_t from_ns, std::int64_t to_ns, Eigen::VectorXd& x, Eigen::MatrixXd& p) const {
  const double dt = 1e-9 * static_cast<double>(to_ns - from_ns);
  if (dt <= 0) return;
  const int d = dims();
  const int n = static_cast<int>(x.size());
  Eigen::MatrixXd f = Eigen::MatrixXd::Identity(n, n);
  f.block(0, d, d, d) = dt * Eigen::MatrixXd::Identity(d, d);
  x = f * x;
  p = f * p * f.transpose();
  // White-noise acceleration of density q per axis; biases drift as a random walk.
  const double q = options_.process_noise;
  for (int k = 0; k < d; ++k) {
    p(k, k) += q * dt * dt * dt / 3;
    p(k, d + k) += q * dt * dt / 2;
    p(d + k, k) += q * dt * dt / 2;
    p(d + k, d + k) += q * dt;
  }
  if (!bias_locked_)
    for (int k = 2 * d; k < n; ++k) p(k, k) += options_.bias_drift * options_.bias_drift * dt;
}

RangeUpdate RangeTracker::add_position(std::int64_t t_ns, const Eigen::Vector3d& position,
                                       const Eigen::Matrix3d& covariance) {
  if (!position.allFinite() || !covariance.allFinite() || covariance.diagonal().minCoeff() < 0)
    return RangeUpdate::kInvalid;
  Pending r{t_ns, -1, position, 1.0, 1.0};
  r.kind = Kind::kPosition;
  r.covariance = covariance;
  unlock_bias();
  return add(r);
}

RangeUpdate RangeTracker::add_speed(std::int64_t t_ns, double speed_mps, double sigma_mps) {
  Pending r{t_ns, -1, Eigen::Vector3d::Zero(), speed_mps, sigma_mps};
  r.kind = Kind::kSpeed;
  return add(r);
}

RangeUpdate RangeTracker::add(const Pending& r) {
  const bool value_ok = r.kind == Kind::kSpeed ? r.range_m >= 0 : r.range_m > 0;  // a robot may stand still
  if (!std::isfinite(r.range_m) || !value_ok || !std::isfinite(r.sigma_m) || r.sigma_m <= 0)
    return RangeUpdate::kInvalid;
  if (!started_ || r.t_ns >= t_ns_) return apply(r);
  // Older than the track: replayed in its place if it is within the reorder window (the state
  // before it restored, it applied, every newer range applied again), else left out.
  if (r.t_ns < base_.t_ns) return RangeUpdate::kOutOfOrder;
  std::size_t first_newer = 0;
  while (first_newer < history_.size() && history_[first_newer].range.t_ns <= r.t_ns) ++first_newer;
  restore(first_newer == 0 ? base_ : history_[first_newer - 1].after);
  std::vector<Pending> newer;
  for (std::size_t i = first_newer; i < history_.size(); ++i) newer.push_back(history_[i].range);
  history_.resize(first_newer);
  const RangeUpdate result = apply(r);
  replaying_ = true;
  for (const Pending& q : newer) apply(q);
  replaying_ = false;
  ++replayed_;
  return result;
}

RangeTracker::Snapshot RangeTracker::snapshot() const { return {t_ns_, x_, p_, rejections_in_a_row_}; }

void RangeTracker::restore(const Snapshot& s) {
  t_ns_ = s.t_ns;
  x_ = s.x;
  p_ = s.p;
  rejections_in_a_row_ = s.rejections;
  // A state from before the biases were unlocked: they get their prior, as unlock_bias() gave.
  if (has_bias_ && !bias_locked_)
    for (int k = 2 * dims(); k < static_cast<int>(x_.size()); ++k)
      if (p_(k, k) == 0) p_(k, k) = options_.bias_sigma_m * options_.bias_sigma_m;
}

void RangeTracker::remember(const Pending& r) {
  history_.push_back({r, snapshot()});
  const auto window = static_cast<std::int64_t>(options_.reorder_window_s * 1e9);
  while (!history_.empty() && history_.front().range.t_ns < t_ns_ - window) {
    base_ = std::move(history_.front().after);
    history_.pop_front();
  }
}

RangeUpdate RangeTracker::apply(const Pending& r) {
  const bool gap = started_ && 1e-9 * static_cast<double>(r.t_ns - t_ns_) > options_.max_gap_s;
  // A speed says nothing of where the tag is: it neither starts a track nor restarts one.
  if (r.kind == Kind::kSpeed && (!started_ || gap)) return RangeUpdate::kUnused;
  if (gap) {
    started_ = false;  // lost for too long: start over from a new fix
    history_.clear();
    if (!replaying_) ++restarts_;
  }
  if (!started_) return r.kind == Kind::kPosition ? start_at(r) : collect(r);

  Eigen::VectorXd x = x_;
  Eigen::MatrixXd p = p_;
  propagate(t_ns_, r.t_ns, x, p);
  if (r.kind == Kind::kPosition) return update_position(r, x, p);
  if (r.kind == Kind::kSpeed) return update_speed(r, x, p);
  const int d = dims();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  position.head(d) = x.head(d);
  if (options_.known_height) position.z() = *options_.known_height;
  const Eigen::Vector3d delta = position - r.reference;
  const double distance = std::max(delta.norm(), 1e-6);
  const bool biased = has_bias_ && r.anchor >= 0;
  const int n = static_cast<int>(x.size());
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(1, n);
  h.leftCols(d) = (delta / distance).head(d).transpose();
  if (biased) h(0, 2 * d + r.anchor) = 1.0;
  const double predicted = distance + (biased ? x(2 * d + r.anchor) : 0.0);
  const double innovation = r.range_m - predicted;
  const double s = (h * p * h.transpose())(0, 0) + r.sigma_m * r.sigma_m;

  // Time moves on whether the range is used or not: the next range predicts from here.
  t_ns_ = r.t_ns;
  x_ = x;
  p_ = p;
  if (options_.gate_sigmas > 0 && innovation * innovation > options_.gate_sigmas * options_.gate_sigmas * s) {
    if (!replaying_) ++rejected_;
    if (++rejections_in_a_row_ >= options_.restart_after_rejections) {
      started_ = false;
      if (!replaying_) ++restarts_;
      history_.clear();
      return RangeUpdate::kRejected;
    }
    remember(r);
    return RangeUpdate::kRejected;
  }
  rejections_in_a_row_ = 0;
  update_linear(h, Eigen::VectorXd::Constant(1, innovation), Eigen::MatrixXd::Constant(1, 1, r.sigma_m * r.sigma_m), x,
                p);
  if (!replaying_) ++accepted_;
  remember(r);
  return RangeUpdate::kAccepted;
}

void RangeTracker::update_linear(const Eigen::MatrixXd& h, const Eigen::VectorXd& innovation, const Eigen::MatrixXd& r,
                                 const Eigen::VectorXd& x, const Eigen::MatrixXd& p) {
  const int n = static_cast<int>(x.size());
  const int m = static_cast<int>(h.rows());
  const Eigen::MatrixXd s = h * p * h.transpose() + r;
  const Eigen::MatrixXd k = p * h.transpose() * s.ldlt().solve(Eigen::MatrixXd::Identity(m, m));
  x_ = x + k * innovation;
  // Joseph form: stays symmetric and positive definite over hundreds of thousands of updates.
  const Eigen::MatrixXd i_kh = Eigen::MatrixXd::Identity(n, n) - k * h;
  p_ = i_kh * p * i_kh.transpose() + k * r * k.transpose();
}

RangeUpdate RangeTracker::update_position(const Pending& r, const Eigen::VectorXd& x, const Eigen::MatrixXd& p) {
  const int d = dims();
  const int n = static_cast<int>(x.size());
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(d, n);
  h.leftCols(d).setIdentity();
  // A floor on the reference's variance (0.1 mm): a camera fix is never exact, and a zero would
  // make the update singular at a known height's z.
  const Eigen::MatrixXd r_cov = r.covariance.topLeftCorner(d, d) + 1e-8 * Eigen::MatrixXd::Identity(d, d);
  t_ns_ = r.t_ns;
  update_linear(h, r.reference.head(d) - x.head(d), r_cov, x, p);
  rejections_in_a_row_ = 0;
  if (!replaying_) ++positions_;
  remember(r);
  return RangeUpdate::kAccepted;
}

RangeUpdate RangeTracker::update_speed(const Pending& r, const Eigen::VectorXd& x, const Eigen::MatrixXd& p) {
  const int d = dims();
  const int n = static_cast<int>(x.size());
  const Eigen::VectorXd v = x.segment(d, d);
  const double speed = v.norm();
  const bool still = r.range_m < 2 * r.sigma_m;
  if (!still && speed < 1e-3) return RangeUpdate::kUnused;  // moving, but which way is not known
  Eigen::MatrixXd h;
  Eigen::VectorXd innovation;
  Eigen::MatrixXd r_cov;
  if (still) {  // velocity 0 on every axis; the measured speed itself is part of the doubt
    h = Eigen::MatrixXd::Zero(d, n);
    h.block(0, d, d, d).setIdentity();
    innovation = -v;
    r_cov = (r.sigma_m * r.sigma_m + r.range_m * r.range_m) * Eigen::MatrixXd::Identity(d, d);
  } else {  // |v| along the track's own direction of travel
    h = Eigen::MatrixXd::Zero(1, n);
    h.block(0, d, 1, d) = (v / speed).transpose();
    innovation = Eigen::VectorXd::Constant(1, r.range_m - speed);
    r_cov = Eigen::MatrixXd::Constant(1, 1, r.sigma_m * r.sigma_m);
  }
  t_ns_ = r.t_ns;
  x_ = x;
  p_ = p;
  const Eigen::MatrixXd s = h * p * h.transpose() + r_cov;
  const double mahalanobis2 = innovation.dot(s.ldlt().solve(innovation));
  const double gate = options_.gate_sigmas;
  if (gate > 0 && mahalanobis2 > gate * gate * static_cast<double>(innovation.size())) {
    // Wheels that slip, a robot carried: left out, but not counted against the ranges.
    if (!replaying_) ++rejected_;
    remember(r);
    return RangeUpdate::kRejected;
  }
  update_linear(h, innovation, r_cov, x, p);
  if (!replaying_) ++speeds_;
  remember(r);
  return RangeUpdate::kAccepted;
}

RangeUpdate RangeTracker::start_at(const Pending& r) {
  // The track starts where the other source saw the tag.
  const int d = dims();
  start(r.t_ns, r.reference, r.covariance.topLeftCorner(d, d) + 1e-6 * Eigen::MatrixXd::Identity(d, d));
  if (!replaying_) ++positions_;
  return RangeUpdate::kStarted;
}

void RangeTracker::start(std::int64_t t_ns, const Eigen::Vector3d& position, const Eigen::MatrixXd& covariance) {
  // Position as given, the velocity unknown (1 m/s per axis); the biases learnt so far kept.
  const int d = dims();
  x_.head(2 * d).setZero();
  x_.head(d) = position.head(d);
  p_.topRows(2 * d).setZero();
  p_.leftCols(2 * d).setZero();
  p_.topLeftCorner(d, d) = covariance;
  p_.block(d, d, d, d) = Eigen::MatrixXd::Identity(d, d);
  t_ns_ = t_ns;
  started_ = true;
  rejections_in_a_row_ = 0;
  pending_.clear();
  history_.clear();
  base_ = snapshot();
}

RangeUpdate RangeTracker::collect(const Pending& r) {
  pending_.push_back(r);
  const auto window = static_cast<std::int64_t>(options_.init_window_s * 1e9);
  std::erase_if(pending_, [&](const Pending& q) { return q.t_ns < r.t_ns - window || q.t_ns > r.t_ns; });
  // The latest range to each reference (mobile ones are each their own reference).
  std::map<int, const Pending*> latest;
  std::vector<const Pending*> mobile;
  for (const Pending& q : pending_) {
    if (q.anchor < 0) {
      // A robot ranged to again (within 5 cm of where it was): its latest range only.
      std::erase_if(mobile, [&](const Pending* m) { return (m->reference - q.reference).norm() < 0.05; });
      mobile.push_back(&q);
    } else if (!latest.count(q.anchor) || latest[q.anchor]->t_ns <= q.t_ns) {
      latest[q.anchor] = &q;
    }
  }
  const int d = dims();
  std::vector<RangeToAnchor> ranges;
  for (const auto& [anchor, q] : latest) {
    const double bias = has_bias_ ? x_(2 * d + anchor) : 0.0;
    ranges.push_back({q->reference, q->range_m - bias, q->sigma_m});
  }
  for (const Pending* q : mobile) ranges.push_back({q->reference, q->range_m, q->sigma_m});
  if (static_cast<int>(ranges.size()) < d + 1) return RangeUpdate::kInitialising;
  RangeSolveOptions solve;
  solve.known_height = options_.known_height;
  solve.z_range = options_.z_range;
  const RangeFix fix = fix_least_squares(ranges, solve);
  if (!fix.ok) return RangeUpdate::kInitialising;
  // The fix's covariance inflated for the motion within the window.
  start(r.t_ns, fix.position, 4.0 * fix.covariance.topLeftCorner(d, d) + 1e-4 * Eigen::MatrixXd::Identity(d, d));
  return RangeUpdate::kStarted;
}

std::optional<RangeTrackState> RangeTracker::state() const { return predict(t_ns_); }

std::optional<RangeTrackState> RangeTracker::predict(std::int64_t t_ns) const {
  if (!started_) return std::nullopt;
  return state_from(snapshot(), std::max(t_ns, t_ns_));
}

std::optional<RangeTrackState> RangeTracker::state_at(std::int64_t t_ns) const {
  if (!started_) return std::nullopt;
  if (t_ns >= t_ns_) return predict(t_ns);
  if (t_ns < base_.t_ns) return std::nullopt;
  const Snapshot* from = &base_;
  for (const Applied& a : history_)
    if (a.range.t_ns <= t_ns) from = &a.after;
  return state_from(*from, t_ns);
}

RangeTrackState RangeTracker::state_from(const Snapshot& from, std::int64_t t_ns) const {
  Eigen::VectorXd x = from.x;
  Eigen::MatrixXd p = from.p;
  propagate(from.t_ns, t_ns, x, p);
  const int d = dims();
  RangeTrackState s;
  s.t_ns = t_ns;
  s.position.head(d) = x.head(d);
  s.velocity.head(d) = x.segment(d, d);
  if (options_.known_height) s.position.z() = *options_.known_height;
  s.covariance.topLeftCorner(d, d) = p.topLeftCorner(d, d);
  return s;
}

std::vector<double> RangeTracker::biases() const {
  std::vector<double> out(anchors_.size(), 0.0);
  if (has_bias_)
    for (std::size_t k = 0; k < anchors_.size(); ++k) out[k] = x_(2 * dims() + static_cast<int>(k));
  return out;
}

}  // namespace ips
