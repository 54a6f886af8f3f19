// Tracking between frames against the simulator's exact truth: a marker that appears is
// acquired within the stated number of frames, a marker that jumps is re-acquired on the same
// frame, and tracking gives the full search's markers and corners.
#include "ips/detect/tracker.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <tuple>

#include <gtest/gtest.h>

#include "ips/capture/jpeg_decoder.h"
#include "ips/capture/jpeg_region_decoder.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/sim/renderer.h"
#include "moving_markers.h"

namespace {

using namespace ips_test;  // NOLINT: the helpers of moving_markers.h
using ips::sim::CameraRenderer;
using ips::sim::Scene;

TEST(Tracker, RejectsInvalidOptions) {
  ips::TrackerOptions o;
  o.full_search_period = 0;
  EXPECT_THROW(ips::DetectionTracker{o}, ips::InputError);
  o = {};
  o.roi_margin = 0.1;
  EXPECT_THROW(ips::DetectionTracker{o}, ips::InputError);
}

// One marker tracked at 1 m/s while three others appear on frames that are not full-search
// frames (period 6, phase 0: full searches on frames 0, 6, 12, 18, 24): each is acquired
// within full_search_period frames counting the frame it appears in, and between full
// searches only ROIs are searched.
TEST(Tracker, MarkerAppearingMidSequenceIsAcquiredWithinThePeriod) {
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {}};
  seq.movers.push_back({.id = 3, .x = C.x() - 0.6, .y = C.y() - 0.3, .vx = 1.0, .turn = 1.0});
  seq.movers.push_back(
      {.id = 11, .x = C.x() + 0.5, .y = C.y() + 0.4, .vy = -0.3, .from = 7});  // worst case: next full at 12
  seq.movers.push_back({.id = 25, .x = C.x() - 0.9, .y = C.y() + 0.5, .vx = 0.5, .from = 11});  // best: full at 12
  seq.movers.push_back(
      {.id = 42, .length = 0.075, .x = C.x() + 1.6, .y = C.y() - 0.8, .from = 14});  // small, at the edge
  ips::TrackerOptions opt;
  const int period = opt.full_search_period;
  ips::DetectionTracker tracker(opt, 0);
  ips::Detector detector;
  const ips::CameraModel& cam = r.camera().model;
  std::map<int, int> acquired;
  int roi_frames = 0;
  for (int f = 0; f < 26; ++f) {
    std::vector<ips::sim::MarkerTruth> truth;
    const cv::Mat gray = seq.frame(f, truth);
    const bool full = tracker.plan(gray.size()).full;
    roi_frames += full ? 0 : 1;
    const auto found = tracker.track(detector, gray, &cam);
    expect_true_markers(found, truth, f);
    ASSERT_NE(find(found, 3), nullptr) << "tracked marker lost at frame " << f;
    for (const auto& d : found)
      if (!acquired.count(d.id)) acquired[d.id] = f;
  }
  for (const auto& m : seq.movers) {
    ASSERT_TRUE(acquired.count(m.id)) << "marker " << m.id << " never acquired";
    EXPECT_LE(acquired[m.id] - m.from + 1, period) << "marker " << m.id << " appeared at frame " << m.from;
  }
  EXPECT_EQ(acquired[11], 12);                  // not before the next full search: the bound is reached
  EXPECT_GE(roi_frames, 26 - 26 / period - 2);  // nearly every other frame searched ROIs only
}

// A tracked marker that jumps 1 m between two frames (far outside its ROI) is found on the
// frame it jumps, at its true corners: the lost track makes that frame a full search.
TEST(Tracker, MarkerThatJumpsIsReacquiredOnTheSameFrame) {
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {}};
  seq.movers.push_back({.id = 7, .x = C.x() - 0.5, .y = C.y(), .vx = 0.8, .jump_at = 9, .jump_x = 0.3, .jump_y = 0.6});
  seq.movers.push_back({.id = 8, .x = C.x() + 0.8, .y = C.y() - 0.4, .vy = 0.5});
  ips::DetectionTracker tracker({}, 0);
  ips::Detector detector;
  for (int f = 0; f < 12; ++f) {
    std::vector<ips::sim::MarkerTruth> truth;
    const cv::Mat gray = seq.frame(f, truth);
    const auto found = tracker.track(detector, gray, &r.camera().model);
    expect_true_markers(found, truth, f);
    EXPECT_NE(find(found, 7), nullptr) << "frame " << f;
    EXPECT_NE(find(found, 8), nullptr) << "frame " << f;
  }
  EXPECT_EQ(tracker.counters().fallbacks, 1u);                // the jump, and nothing else
  EXPECT_EQ(tracker.counters().full_searches, 1u + 1u + 1u);  // frames 0, 6 and the jump
}

// Tracking on and off on the same frames: the same markers with corners within 0.05 px, for
// five markers moving at up to 1 m/s (one leaves the view half way: its track ends).
TEST(Tracker, GivesTheFullSearchMarkersAndCorners) {
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {}};
  seq.movers.push_back({.id = 1, .x = C.x() - 0.8, .y = C.y() - 0.4, .vx = 1.0, .turn = 0.5});
  seq.movers.push_back({.id = 2, .x = C.x() + 0.6, .y = C.y() + 0.3, .vx = -0.7, .vy = -0.7});
  seq.movers.push_back({.id = 5, .x = C.x(), .y = C.y() + 0.45, .vy = -0.2, .yaw = 1.0, .turn = -2.0});
  seq.movers.push_back({.id = 9, .x = C.x() + 1.0, .y = C.y() - 0.5});
  seq.movers.push_back({.id = 14, .length = 0.075, .x = C.x() - 1.2, .y = C.y() + 0.5, .vx = 0.3, .until = 10});
  ips::DetectionTracker tracker({}, 3);
  ips::Detector tracked_detector, full_detector;
  const ips::CameraModel& cam = r.camera().model;
  int compared = 0, missed = 0;
  for (int f = 0; f < 18; ++f) {
    std::vector<ips::sim::MarkerTruth> truth;
    const cv::Mat gray = seq.frame(f, truth);
    const auto tracked = tracker.track(tracked_detector, gray, &cam);
    const auto full = full_detector.detect(gray, &cam);
    expect_true_markers(full, truth, f);
    missed += static_cast<int>(truth.size() - full.size());
    ASSERT_EQ(tracked.size(), full.size()) << "frame " << f;
    for (const auto& d : full) {
      const auto* t = find(tracked, d.id);
      ASSERT_NE(t, nullptr) << "frame " << f << " marker " << d.id;
      for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_NEAR(t->corners_px[k].x, d.corners_px[k].x, 0.05) << "frame " << f << " marker " << d.id;
        EXPECT_NEAR(t->corners_px[k].y, d.corners_px[k].y, 0.05) << "frame " << f << " marker " << d.id;
      }
      ++compared;
    }
  }
  EXPECT_GE(compared, 18 * 4 + 9);
  EXPECT_EQ(missed, 0);                             // the full search finds every marker (truth), so tracking does too
  EXPECT_LE(tracker.counters().full_searches, 5u);  // frames 0, 3, 9, 15 (+ the marker leaving)
}

// Tracking's shortcut (Detector::refine_known): from corners predicted up to 2.5 px off or
// turned by up to 2 degrees, the full search's corners within 0.05 px; a wrong id, a wrong
// orientation, a prediction too far off, or pixels outside the valid region: refused.
TEST(Tracker, RefineKnownGivesTheFullSearchCornersAndRefusesWhatItCannotVerify) {
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {}};
  seq.movers.push_back({.id = 5, .x = C.x() - 0.7, .y = C.y() + 0.2, .yaw = 0.4});
  seq.movers.push_back({.id = 17, .length = 0.075, .x = C.x() + 1.3, .y = C.y() - 0.6, .yaw = 2.0});
  std::vector<ips::sim::MarkerTruth> truth;
  const cv::Mat gray = seq.frame(0, truth);
  const ips::CameraModel& cam = r.camera().model;
  ips::Detector detector;
  const auto full = detector.detect(gray, &cam);
  ASSERT_EQ(full.size(), 2u);
  const cv::Rect whole(0, 0, gray.cols, gray.rows);
  for (const auto& d : full) {
    ips::Point2 c{0, 0};
    for (const auto& p : d.corners_px) c = {c.x + p.x / 4, c.y + p.y / 4};
    auto moved = [&](double dx, double dy, double turn) {
      ips::MarkerDetection p = d;
      for (auto& q : p.corners_px) {
        const double x = q.x - c.x, y = q.y - c.y;
        q = {c.x + dx + x * std::cos(turn) - y * std::sin(turn), c.y + dy + x * std::sin(turn) + y * std::cos(turn)};
      }
      return p;
    };
    for (const auto& [dx, dy, turn] : {std::tuple{0.0, 0.0, 0.0},
                                       {1.5, -1.0, 0.0},
                                       {-1.0, 1.0, 0.017},
                                       {-2.0, 1.5, 0.0},
                                       {0.0, 0.0, 0.035},
                                       {1.0, 1.0, -0.017}}) {
      ips::MarkerDetection out;
      ASSERT_TRUE(detector.refine_known(gray, moved(dx, dy, turn), whole, &cam, out))
          << "marker " << d.id << " predicted " << dx << ", " << dy << " px off, turned " << turn;
      EXPECT_EQ(out.id, d.id);
      for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_NEAR(out.corners_px[k].x, d.corners_px[k].x, 0.05) << "marker " << d.id;
        EXPECT_NEAR(out.corners_px[k].y, d.corners_px[k].y, 0.05) << "marker " << d.id;
      }
    }
    ips::MarkerDetection out;
    EXPECT_FALSE(detector.refine_known(gray, moved(12, 0, 0), whole, &cam, out)) << d.id;
    ips::MarkerDetection wrong_id = d;
    wrong_id.id = d.id == 5 ? 6 : 16;
    EXPECT_FALSE(detector.refine_known(gray, wrong_id, whole, &cam, out)) << d.id;
    ips::MarkerDetection turned = d;  // the same square a quarter turn off: another corner 0
    std::rotate(turned.corners_px.begin(), turned.corners_px.begin() + 1, turned.corners_px.end());
    EXPECT_FALSE(detector.refine_known(gray, turned, whole, &cam, out)) << d.id;
    // Pixels outside `valid` may not be decoded: a region cutting the marker is refused.
    const cv::Rect cut(0, 0, static_cast<int>(c.x), gray.rows);
    EXPECT_FALSE(detector.refine_known(gray, d, cut, &cam, out)) << d.id;
  }
}

// Tracking off: every frame is a full search.
TEST(Tracker, DisabledSearchesEveryFrameInFull) {
  ips::TrackerOptions o;
  o.enabled = false;
  ips::DetectionTracker tracker(o);
  ips::Detector detector;
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {{.id = 4, .x = C.x(), .y = C.y(), .vx = 0.5}}};
  for (int f = 0; f < 3; ++f) {
    std::vector<ips::sim::MarkerTruth> truth;
    const cv::Mat gray = seq.frame(f, truth);
    EXPECT_TRUE(tracker.plan(gray.size()).full);
    EXPECT_EQ(tracker.track(detector, gray, &r.camera().model).size(), 1u);
  }
  EXPECT_EQ(tracker.counters().full_searches, 3u);
}

// The partial decode gives a full decode's pixels inside the ROIs, and tracking on it finds
// what tracking on the full decode finds: on frames without restart markers (rows above the
// ROIs Huffman-decoded and skipped) and with a restart marker every MCU row or every 3 (only
// the ROIs' rows cut out and decoded).
class RegionDecodeRestarts : public ::testing::TestWithParam<int> {};

TEST_P(RegionDecodeRestarts, RoiPixelsEqualAFullDecode) {
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r,
               {{.id = 4, .x = C.x() - 0.3, .y = C.y(), .vx = 0.5}, {.id = 6, .x = C.x() + 0.9, .y = C.y() + 0.5}},
               GetParam()};
  ips::JpegDecoder full_decoder;
  ips::JpegRegionDecoder region_decoder;
  ips::DetectionTracker tracker;
  ips::Detector detector;
  cv::Mat full, partial;
  int roi_frames = 0;
  for (int f = 0; f < 4; ++f) {
    std::vector<ips::sim::MarkerTruth> truth;
    const auto jpeg = seq.jpeg(f, truth);
    ASSERT_TRUE(full_decoder.decode_gray(jpeg, full));
    const ips::TrackPlan plan = tracker.plan(full.size());
    partial = cv::Mat(full.size(), CV_8UC1, cv::Scalar(0));
    ASSERT_TRUE(region_decoder.decode(jpeg, partial, plan.full ? std::vector<cv::Rect>{} : plan.rois))
        << region_decoder.error();
    if (plan.full) {
      EXPECT_EQ(cv::norm(full, partial, cv::NORM_INF), 0.0);
    } else {
      ++roi_frames;
      ASSERT_EQ(plan.rois.size(), 2u);
      for (const auto& roi : plan.rois) EXPECT_EQ(cv::norm(full(roi), partial(roi), cv::NORM_INF), 0.0);
      // Rows below the lowest ROI's MCU row (or its group of restart_rows MCU rows) were not
      // decoded at all, nor, with restart markers, rows above the highest ROI's.
      const int unit = 16 * std::max(1, GetParam());
      int top = full.rows, bottom = 0;
      for (const auto& roi : plan.rois) {
        top = std::min(top, roi.y / unit * unit);
        bottom = std::max(bottom, (roi.y + roi.height + unit - 1) / unit * unit);
      }
      ASSERT_LT(bottom, full.rows - 16);
      EXPECT_EQ(cv::countNonZero(partial.rowRange(bottom, full.rows)), 0);
      if (GetParam() > 0) {
        ASSERT_GT(top, 0);
        EXPECT_EQ(cv::countNonZero(partial.rowRange(0, top)), 0);
      }
    }
    std::vector<ips::MarkerDetection> found;
    ASSERT_TRUE(tracker.detect(detector, partial, plan, &r.camera().model, found));
    ASSERT_EQ(found.size(), 2u);
    expect_true_markers(found, truth, f);
  }
  EXPECT_EQ(roi_frames, 3);
  // Which path decoded the ROI frames.
  EXPECT_EQ(region_decoder.entered_at_restarts(), GetParam() > 0 ? 3u : 0u);
  EXPECT_EQ(region_decoder.skipped_by_huffman(), GetParam() > 0 ? 0u : 3u);
  EXPECT_EQ(region_decoder.restart_fallbacks(), 0u);
  const std::vector<std::uint8_t> garbage(5000, 0x55);
  EXPECT_FALSE(region_decoder.decode(garbage, partial, {}));
  EXPECT_FALSE(region_decoder.error().empty());
}

INSTANTIATE_TEST_SUITE_P(JpegRegionDecoder, RegionDecodeRestarts, ::testing::Values(0, 1, 3));

}  // namespace
