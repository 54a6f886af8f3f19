// Marker tracking between frames: search the whole frame rarely, and in between
// only regions of interest around where each known marker is predicted to be.
//
// Per camera, frame by frame:
//   - a full-frame search (Detector::detect on the whole image) runs on every
//     `full_search_period`-th frame (the phase is spread over the cameras so they do not all
//     search on the same frame), also when nothing is tracked (an empty view costs a full
//     search per period, not per frame). That periodic search is an *acquisition*: the frame
//     is first tracked as any other (its markers, if any, can be published at once), and the
//     whole-frame search for markers not yet tracked runs after (acquire()): the markers it
//     finds are tracked from the next frame on. Only the first frame and the frame after a
//     reset() are searched in full before anything is reported;
//   - on the other frames each tracked marker's corners are predicted (last corners + image
//     velocity per frame, measured between its last two sightings) and refined from there
//     by the full search's edge refinement, read and verified as the full search does
//     (Detector::refine_known, no candidate search); only where that fails does the detector
//     run in a rectangle a few marker sides around the prediction, with the same candidate
//     search, refinement and verification as the full search (the ROI entry point of
//     Detector); either way a tracked marker has the corners the full search would give it;
//   - a tracked marker not found in its ROI (fast motion, occlusion, left the view) ends its
//     track, and the same frame is searched whole after its other markers (the fallback, an
//     acquisition as above): a marker that jumped is found again there and reported from the
//     next frame on (track(): in the same frame).
// Guarantee: a marker that becomes findable (enters the view, is uncovered) while others are
// tracked is acquired at the latest on the next periodic search: within `full_search_period`
// frames of the first frame it appears in (counting that frame), and reported from the frame
// after (track() reports it in the same frame); sooner if it appears inside an ROI that is
// searched.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "ips/core/observation.h"
#include "ips/detect/detector.h"
#include "ips/geometry/camera_model.h"

namespace ips {

struct TrackerOptions {
  /// detection.tracking: false = every frame is a full-frame search.
  bool enabled = true;
  /// detection.full_search_period: a full-frame search every this many frames (1 = every
  /// frame). It bounds the acquisition of a new marker to this many frames (6 at 30 fps:
  /// 0.2 s) and costs 1/period of a full search per frame on average.
  int full_search_period = 6;
  /// detection.roi_margin: the ROI extends this many marker sides beyond the predicted
  /// marker on every side (plus half the predicted motion, for its uncertainty, and 8 px).
  /// 0.5: a 20 cm marker at 1 m/s moves 1/6 of its side per frame at 30 fps.
  double roi_margin = 0.5;

  bool operator==(const TrackerOptions&) const = default;
};

/// What to search in the next frame.
struct TrackPlan {
  bool full = true;            ///< the whole image
  std::vector<cv::Rect> rois;  ///< otherwise these rectangles (clipped, 16-px aligned; may overlap)
  /// After the ROIs, acquire() on the whole image (a periodic search while markers are tracked).
  bool acquire = false;
};

class DetectionTracker {
 public:
  /// `phase` shifts the full-search frames (use the camera index: cameras then search on
  /// different frames). Throws ips::InputError for an invalid option.
  explicit DetectionTracker(const TrackerOptions& options = {}, int phase = 0);

  /// The search the next frame needs (an image of `image` size).
  TrackPlan plan(cv::Size image) const;

  /// Runs `plan` with `detector` on `gray` (for an ROI plan only the ROIs' pixels need to be
  /// valid: a partial JPEG decode is enough). Returns false when a tracked marker was not found
  /// near its prediction: `out` holds the markers that were, their tracks go on, the lost
  /// one's ends, and the caller should call acquire() on the same frame decoded whole (which
  /// finds the lost marker wherever it is now).
  bool detect(Detector& detector, const cv::Mat& gray, const TrackPlan& plan, const CameraModel* camera,
              std::vector<MarkerDetection>& out);

  /// After detect() with a plan that says `acquire`, or one that returned false, on the same
  /// frame decoded whole:
  /// searches the whole image and starts tracking the markers found that are not tracked yet
  /// (they are predicted from the next frame on). Returns those new markers.
  std::vector<MarkerDetection> acquire(Detector& detector, const cv::Mat& gray, const CameraModel* camera);

  /// plan() + detect() + acquire() when due, for a fully decoded frame; the markers acquire()
  /// finds are in the result too.
  std::vector<MarkerDetection> track(Detector& detector, const cv::Mat& gray, const CameraModel* camera);

  /// Forgets every track (e.g. the source was reopened); the next frame is a full search.
  void reset();

  const TrackerOptions& options() const { return options_; }

  struct Counters {
    std::uint64_t frames = 0;         ///< frames processed
    std::uint64_t full_searches = 0;  ///< of which searched in full (periodic or fallback)
    std::uint64_t acquisitions = 0;   ///< whole-frame searches after tracking the frame (acquire())
    std::uint64_t acquired = 0;       ///< markers acquire() started tracking
    std::uint64_t fallbacks = 0;      ///< frames whose tracked marker was not found near its prediction
    std::uint64_t predicted = 0;      ///< markers found from their predicted corners alone
    std::uint64_t roi_searches = 0;   ///< ROIs searched (a tracked marker not found so)
  };
  const Counters& counters() const { return counters_; }

 private:
  struct Track {
    MarkerDetection last;    ///< corners at the last sighting
    Point2 velocity{0, 0};   ///< centre motion per frame, px
    std::int64_t frame = 0;  ///< frame index of the last sighting
  };
  void update(const std::vector<MarkerDetection>& found, bool full);
  MarkerDetection predicted(const Track& t) const;        ///< its corners in the next frame
  cv::Rect roi_of(const Track& t, cv::Size image) const;  ///< where to search for it
  double reach(const Track& t) const;

  TrackerOptions options_;
  int phase_ = 0;
  std::int64_t frame_ = 0;  ///< index of the next frame
  bool force_full_ = true;
  std::vector<Track> tracks_;
  Counters counters_;
};

}  // namespace ips
