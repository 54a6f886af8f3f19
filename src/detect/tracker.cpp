#include "ips/detect/tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "ips/core/error.h"

namespace ips {
namespace {

// ROIs are aligned to this grid: even coordinates keep the half-scale candidate search on the
// same pixel grid as the full frame's (same coarse corners), and 16 px is a 4:2:0 JPEG's MCU,
// the unit a partial decode works in.
constexpr int kAlign = 16;
// Added to every ROI margin, px: room for the edge refinement's samples and the threshold
// window around a marker that barely moved.
constexpr double kMinMarginPx = 8.0;

Point2 centre(const MarkerDetection& d) {
  Point2 c{0, 0};
  for (const auto& p : d.corners_px) {
    c.x += p.x / 4;
    c.y += p.y / 4;
  }
  return c;
}

double side(const MarkerDetection& d) {
  double s = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    s += std::hypot(d.corners_px[(i + 1) % 4].x - d.corners_px[i].x, d.corners_px[(i + 1) % 4].y - d.corners_px[i].y);
  }
  return s / 4;
}

int floor_to(double v, int a) { return static_cast<int>(std::floor(v / a)) * a; }
int ceil_to(double v, int a) { return static_cast<int>(std::ceil(v / a)) * a; }

}  // namespace

DetectionTracker::DetectionTracker(const TrackerOptions& options, int phase) : options_(options) {
  if (options_.full_search_period < 1 || options_.full_search_period > 1000) {
    throw InputError("tracker: full_search_period must be 1..1000, got " + std::to_string(options_.full_search_period));
  }
  if (!(options_.roi_margin >= 0.25) || !std::isfinite(options_.roi_margin)) {
    throw InputError("tracker: roi_margin must be at least 0.25 marker sides");
  }
  phase_ = ((phase % options_.full_search_period) + options_.full_search_period) % options_.full_search_period;
}

void DetectionTracker::reset() {
  tracks_.clear();
  force_full_ = true;
}

MarkerDetection DetectionTracker::predicted(const Track& t) const {
  const auto elapsed = static_cast<double>(frame_ - t.frame);
  MarkerDetection p = t.last;
  for (auto& c : p.corners_px) {
    c.x += t.velocity.x * elapsed;
    c.y += t.velocity.y * elapsed;
  }
  return p;
}

cv::Rect DetectionTracker::roi_of(const Track& t, cv::Size image) const {
  const auto elapsed = static_cast<double>(frame_ - t.frame);
  const double dx = t.velocity.x * elapsed, dy = t.velocity.y * elapsed;
  double x0 = std::numeric_limits<double>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  for (const auto& c : predicted(t).corners_px) {
    x0 = std::min(x0, c.x);
    x1 = std::max(x1, c.x);
    y0 = std::min(y0, c.y);
    y1 = std::max(y1, c.y);
  }
  // The marker's own size (it may turn, tilt, grow) plus the prediction's uncertainty:
  // up to half the predicted motion again (acceleration, a velocity measured on noise).
  const double m = options_.roi_margin * side(t.last) + 0.5 * std::hypot(dx, dy) + kMinMarginPx;
  cv::Rect r(cv::Point(floor_to(x0 - m, kAlign), floor_to(y0 - m, kAlign)),
             cv::Point(ceil_to(x1 + m, kAlign), ceil_to(y1 + m, kAlign)));
  return r & cv::Rect(0, 0, image.width, image.height);
}

TrackPlan DetectionTracker::plan(cv::Size image) const {
  TrackPlan p;
  if (!options_.enabled || force_full_) return p;
  if ((frame_ + phase_) % options_.full_search_period == 0) {
    // A search on every frame is just that. Otherwise the tracked markers (none, in an empty
    // view: the frame then needs no pixel) go out before the search for new ones.
    if (options_.full_search_period == 1) return p;
    p.acquire = true;
  }
  p.full = false;
  for (const auto& t : tracks_) {
    const cv::Rect r = roi_of(t, image);
    if (r.width >= 8 && r.height >= 8) p.rois.push_back(r);
  }
  // Two ROIs become their bounding box when that is no larger than the two together (a
  // marker close to another); otherwise they stay apart, overlap or not (markers in lanes
  // side by side: the bounding box of a row of ROIs is mostly floor), and a marker found in
  // two is reported once (detect()).
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < p.rois.size() && !merged; ++i) {
      for (std::size_t j = i + 1; j < p.rois.size() && !merged; ++j) {
        if ((p.rois[i] | p.rois[j]).area() <= p.rois[i].area() + p.rois[j].area()) {
          p.rois[i] |= p.rois[j];
          p.rois.erase(p.rois.begin() + static_cast<std::ptrdiff_t>(j));
          merged = true;
        }
      }
    }
  }
  return p;
}

bool DetectionTracker::detect(Detector& detector, const cv::Mat& gray, const TrackPlan& plan, const CameraModel* camera,
                              std::vector<MarkerDetection>& out) {
  out.clear();
  if (plan.full) {
    out = detector.detect(gray, camera);
    update(out, true);
    return true;
  }
  // Overlapping ROIs: the same marker (same id, same place) found twice is kept once.
  auto add = [&](const MarkerDetection& d) {
    const Point2 c = centre(d);
    const bool seen = std::any_of(out.begin(), out.end(), [&](const MarkerDetection& o) {
      const Point2 co = centre(o);
      return o.id == d.id && std::hypot(co.x - c.x, co.y - c.y) < 0.25 * side(d);
    });
    if (!seen) out.push_back(d);
  };
  // Each tracked marker first from its predicted corners alone (Detector::refine_known: the
  // full search's refinement and verification without its candidate search); an ROI is
  // searched only where that failed (the prediction too far off: a bounce, a jump, a
  // marker turning fast, an occlusion). A marker that appears in the ROI of a marker found
  // so waits for the next full search, as one appearing elsewhere does.
  const cv::Size image(gray.cols, gray.rows);
  std::vector<bool> search(plan.rois.size(), false);
  for (const auto& t : tracks_) {
    const cv::Rect own = roi_of(t, image);
    const MarkerDetection p = predicted(t);
    // The plan's ROI holding this marker's own (merged ROIs hold several); pixels outside
    // the plan's ROIs may not be decoded.
    const auto holder =
        std::find_if(plan.rois.begin(), plan.rois.end(), [&](const cv::Rect& r) { return (r & own) == own; });
    MarkerDetection d;
    if (holder != plan.rois.end() && detector.refine_known(gray, p, *holder, camera, d)) {
      add(d);
      ++counters_.predicted;
      continue;
    }
    for (std::size_t i = 0; i < plan.rois.size(); ++i)
      if ((plan.rois[i] & own).area() > 0) search[i] = true;
  }
  for (std::size_t i = 0; i < plan.rois.size(); ++i) {
    if (!search[i]) continue;
    ++counters_.roi_searches;
    for (const auto& d : detector.detect(gray, plan.rois[i], camera)) add(d);
  }
  // Every tracked marker should be found again near its prediction; one that is not (it
  // jumped, was covered, left the view) ends its track, and the frame is to be searched whole
  // after (acquire(): the caller decodes it whole if it decoded only the ROIs).
  bool lost = false;
  std::vector<bool> used(out.size(), false);
  for (const auto& t : tracks_) {
    const auto elapsed = static_cast<double>(frame_ - t.frame);
    const Point2 c0 = centre(t.last);
    const Point2 expected{c0.x + t.velocity.x * elapsed, c0.y + t.velocity.y * elapsed};
    const double r = reach(t);
    bool found = false;
    for (std::size_t i = 0; i < out.size() && !found; ++i) {
      const Point2 c = centre(out[i]);
      if (!used[i] && out[i].id == t.last.id && std::hypot(c.x - expected.x, c.y - expected.y) <= r) {
        used[i] = found = true;
      }
    }
    lost = lost || !found;
  }
  if (lost) ++counters_.fallbacks;
  update(out, false);
  return !lost;
}

std::vector<MarkerDetection> DetectionTracker::acquire(Detector& detector, const cv::Mat& gray,
                                                       const CameraModel* camera) {
  ++counters_.full_searches;
  ++counters_.acquisitions;
  std::vector<MarkerDetection> fresh;
  // detect() has moved on to the next frame: the tracks hold this frame's sightings.
  const std::int64_t frame = frame_ - 1;
  const std::size_t tracked = tracks_.size();
  for (const auto& d : detector.detect(gray, camera)) {
    const Point2 c = centre(d);
    const bool known =
        std::any_of(tracks_.begin(), tracks_.begin() + static_cast<std::ptrdiff_t>(tracked), [&](const Track& t) {
          const Point2 ct = centre(t.last);
          return t.frame == frame && t.last.id == d.id && std::hypot(ct.x - c.x, ct.y - c.y) < 0.5 * side(d);
        });
    if (known) continue;
    Track t;
    t.last = d;
    t.frame = frame;
    tracks_.push_back(t);
    fresh.push_back(d);
  }
  counters_.acquired += fresh.size();
  return fresh;
}

std::vector<MarkerDetection> DetectionTracker::track(Detector& detector, const cv::Mat& gray,
                                                     const CameraModel* camera) {
  std::vector<MarkerDetection> out;
  const TrackPlan p = plan(gray.size());
  if (!detect(detector, gray, p, camera, out) || p.acquire)
    for (auto& d : acquire(detector, gray, camera)) out.push_back(std::move(d));
  return out;
}

double DetectionTracker::reach(const Track& t) const {
  // How far from its prediction a tracked marker's centre may be found: its ROI.
  const auto elapsed = static_cast<double>(frame_ - t.frame);
  return (options_.roi_margin + 1) * side(t.last) + std::hypot(t.velocity.x, t.velocity.y) * elapsed + kMinMarginPx;
}

void DetectionTracker::update(const std::vector<MarkerDetection>& found, bool full) {
  ++counters_.frames;
  if (full) ++counters_.full_searches;
  std::vector<Track> next;
  next.reserve(found.size());
  std::vector<bool> matched(tracks_.size(), false);
  for (const auto& d : found) {
    const Point2 c = centre(d);
    // The nearest unmatched track of the same id (ids may repeat in a view).
    std::size_t best = tracks_.size();
    double best_dist = std::numeric_limits<double>::max();
    for (std::size_t i = 0; i < tracks_.size(); ++i) {
      if (matched[i] || tracks_[i].last.id != d.id) continue;
      const auto elapsed = static_cast<double>(frame_ - tracks_[i].frame);
      const Point2 c0 = centre(tracks_[i].last);
      const double dist =
          std::hypot(c0.x + tracks_[i].velocity.x * elapsed - c.x, c0.y + tracks_[i].velocity.y * elapsed - c.y);
      if (dist < best_dist) {
        best_dist = dist;
        best = i;
      }
    }
    Track t;
    t.last = d;
    t.frame = frame_;
    if (best < tracks_.size() && best_dist > reach(tracks_[best])) {
      matched[best] = true;   // found by the full search far from its prediction (it jumped):
      best = tracks_.size();  // its motion so far says nothing about the next frame
    }
    if (best < tracks_.size()) {
      matched[best] = true;
      const Point2 c0 = centre(tracks_[best].last);
      const auto elapsed = static_cast<double>(std::max<std::int64_t>(1, frame_ - tracks_[best].frame));
      t.velocity = {(c.x - c0.x) / elapsed, (c.y - c0.y) / elapsed};
    }
    next.push_back(t);
  }
  // A full search that did not find a track's marker ends it; an ROI pass found them all.
  tracks_ = std::move(next);
  force_full_ = false;
  ++frame_;
}

}  // namespace ips
