// One camera's detection step on a frame as a source hands it over: the tracker
// says what to search (the whole image every `full_search_period` frames, else ROIs around
// the predicted markers), and a frame that arrives undecoded (Frame::jpeg, a deferring source)
// is decoded only as far as that search needs:
//   - a tracked frame: only the ROIs' rows and columns (JpegRegionDecoder; pixels inside the
//     ROIs equal a full decode's, the rest of `gray` is stale);
//   - a full-search frame (the first, or the first after a reset) or a frame the caller wants
//     whole (the web view's camera image): the whole image;
//   - a periodic search, and a frame whose tracked marker was not found near its prediction
//     (an acquisition): detect() tracks the frame as any other, so that its markers can be
//     published at once; the caller then calls acquire(), which searches it whole for markers
//     not yet tracked (decoding it whole first if it was decoded in its ROIs).
// A frame that arrives decoded (Frame::gray) is searched the same way, without decoding.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ips/capture/frame_source.h"
#include "ips/capture/jpeg_region_decoder.h"
#include "ips/core/observation.h"
#include "ips/detect/detector.h"
#include "ips/detect/tracker.h"
#include "ips/geometry/camera_model.h"

namespace ips {

class TrackedFrameDetector {
 public:
  /// `phase`: the camera index (DetectionTracker). Throws ips::InputError for bad options.
  TrackedFrameDetector(const DetectorOptions& detection, const TrackerOptions& tracking, int phase = 0);

  /// Detects the markers of `frame` into `out`. `whole_image`: frame.gray must hold the whole
  /// decoded image afterwards (otherwise, for an undecoded frame, only the searched regions of
  /// frame.gray are valid). Returns false for a JPEG that cannot be decoded (error() says why;
  /// `out` is empty and the tracks are kept for the next frame).
  bool detect(Frame& frame, const CameraModel* camera, bool whole_image, std::vector<MarkerDetection>& out);

  /// True after a detect() whose frame is due a search for new markers.
  bool acquisition_pending() const { return acquire_pending_; }
  /// That search, on the same frame (decoded whole first if it was not): the markers it finds
  /// are tracked from the next frame on. Returns false for a JPEG that cannot be decoded.
  bool acquire(Frame& frame, const CameraModel* camera);

  /// Forgets every track (the source was reopened): the next frame is a full search.
  void reset() { tracker_.reset(); }

  const DetectorOptions& detection() const { return detector_.options(); }
  const TrackerOptions& tracking() const { return tracker_.options(); }
  const DetectionTracker::Counters& tracker_counters() const { return tracker_.counters(); }
  const std::string& error() const { return error_; }

  struct DecodeCounters {
    std::uint64_t whole = 0;            ///< undecoded frames decoded whole
    std::uint64_t regions = 0;          ///< undecoded frames decoded only in their ROIs
    std::uint64_t decode_ns = 0;        ///< time spent decoding (monotonic clock), ns
    std::uint64_t restart_cuts = 0;     ///< of the regions: cut out at restart markers (jpeg_restart.h)
    std::uint64_t restart_damaged = 0;  ///< frames whose restart markers were not where their headers put them
  };
  const DecodeCounters& decode_counters() const { return decode_; }
  /// Why the last frame counted in restart_damaged could not be cut at its restart markers.
  const std::string& restart_problem() const { return decoder_.restart_problem(); }

 private:
  bool decode(Frame& frame, const std::vector<cv::Rect>& rois);

  Detector detector_;
  DetectionTracker tracker_;
  JpegRegionDecoder decoder_;
  DecodeCounters decode_;
  bool acquire_pending_ = false;
  bool decoded_whole_ = false;  // the last detect() left the whole image in frame.gray
  std::string error_;
};

}  // namespace ips
