#include "ips/detect/tracked_frame_detector.h"

#include "ips/core/clock.h"

namespace ips {
namespace {

// A partial decode stops after the lowest ROI and never sees the end of the stream: check that
// it is there (a truncated USB transfer, the usual damage, loses it). Some cameras pad a frame
// after its end-of-image marker, so the last bytes are searched, not just the last two.
bool has_end_of_image(const std::vector<std::uint8_t>& jpeg) {
  constexpr std::size_t kTail = 1024;
  const std::size_t from = jpeg.size() > kTail ? jpeg.size() - kTail : 0;
  for (std::size_t i = jpeg.size(); i-- > from + 1;)
    if (jpeg[i - 1] == 0xFF && jpeg[i] == 0xD9) return true;
  return false;
}

}  // namespace

TrackedFrameDetector::TrackedFrameDetector(const DetectorOptions& detection, const TrackerOptions& tracking, int phase)
    : detector_(detection), tracker_(tracking, phase) {}

bool TrackedFrameDetector::decode(Frame& frame, const std::vector<cv::Rect>& rois) {
  // Never write into an image someone else still holds (the web view's copy of a frame).
  if (frame.gray.u != nullptr && frame.gray.u->refcount > 1) frame.gray.release();
  const std::int64_t t0 = monotonic_ns();
  const bool ok = decoder_.decode(frame.jpeg, frame.gray, rois);
  decode_.decode_ns += static_cast<std::uint64_t>(monotonic_ns() - t0);
  decode_.restart_cuts = decoder_.entered_at_restarts();
  decode_.restart_damaged = decoder_.restart_fallbacks();
  if (!ok) {
    error_ = "corrupt JPEG: " + decoder_.error();
    return false;
  }
  ++(rois.empty() ? decode_.whole : decode_.regions);
  return true;
}

bool TrackedFrameDetector::detect(Frame& frame, const CameraModel* camera, bool whole_image,
                                  std::vector<MarkerDetection>& out) {
  out.clear();
  acquire_pending_ = false;
  decoded_whole_ = frame.jpeg.empty();
  if (frame.jpeg.empty()) {
    const TrackPlan plan = tracker_.plan(frame.gray.size());
    acquire_pending_ = !tracker_.detect(detector_, frame.gray, plan, camera, out) || plan.acquire;
    return true;
  }
  if (!has_end_of_image(frame.jpeg)) {
    error_ = "corrupt JPEG: no end-of-image marker (truncated)";
    return false;
  }
  cv::Size size;
  if (!decoder_.read_size(frame.jpeg, size)) {
    error_ = "corrupt JPEG: " + decoder_.error();
    return false;
  }
  const TrackPlan plan = tracker_.plan(size);
  // An ROI plan with no ROI (nothing tracked is in the image) needs no pixel at all.
  // An acquisition frame is decoded in its ROIs first, like any other, and whole only after
  // its markers went out: their latency is a tracked frame's. Without restart markers that
  // costs the ROIs' decode twice on these frames (~0.4 ms per frame on average at period 6);
  // decoding whole first would save it and put the whole decode (~4.5 ms) in the latency.
  const bool whole = plan.full || whole_image;
  if ((whole || !plan.rois.empty()) && !decode(frame, whole ? std::vector<cv::Rect>{} : plan.rois)) return false;
  decoded_whole_ = whole;
  // A tracked marker not found near its prediction: the frame is searched whole after (acquire()).
  acquire_pending_ = !tracker_.detect(detector_, frame.gray, plan, camera, out) || plan.acquire;
  return true;
}

bool TrackedFrameDetector::acquire(Frame& frame, const CameraModel* camera) {
  if (!acquire_pending_) return true;
  acquire_pending_ = false;
  if (!decoded_whole_ && !decode(frame, {})) return false;
  decoded_whole_ = true;
  tracker_.acquire(detector_, frame.gray, camera);
  return true;
}

}  // namespace ips
