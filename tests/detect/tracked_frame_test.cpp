// The camera thread's detection step from a replayed source to marker positions: JPEG
// frames handed over undecoded by a preloaded file source (FileSource::defer_decode), decoded
// only in the tracker's ROIs on tracked frames, give the same markers, corners (within
// 0.05 px) and camera-frame positions as tracking off (every frame decoded whole and searched
// in full), and the same as the simulator's truth.
#include "ips/detect/tracked_frame_detector.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "ips/capture/file_source.h"
#include "ips/geometry/marker_geometry.h"
#include "moving_markers.h"

namespace {

using namespace ips_test;  // NOLINT: the helpers of moving_markers.h
namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("ips_tracked_frame_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// Reads every frame of a directory once, in order, from a source.
std::vector<ips::Frame> read_all(ips::FileSource& source, int n) {
  std::vector<ips::Frame> frames;
  for (int i = 0; i < n; ++i) {
    ips::Frame f;
    EXPECT_EQ(source.read(f, std::chrono::milliseconds(100)), ips::FrameSource::ReadStatus::kFrame);
    frames.push_back(std::move(f));
  }
  return frames;
}

TEST(TrackedFrameDetector, RoiDecodedReplayGivesTheFullSearchPositions) {
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {}};
  seq.movers.push_back({.id = 1, .x = C.x() - 0.8, .y = C.y() - 0.4, .vx = 1.0, .turn = 0.5});
  seq.movers.push_back({.id = 2, .x = C.x() + 0.6, .y = C.y() + 0.3, .vx = -0.7, .vy = -0.7});
  seq.movers.push_back({.id = 5, .x = C.x(), .y = C.y() + 0.45, .vy = -0.2, .yaw = 1.0, .turn = -2.0});
  // Appears on frame 8 (not a full-search frame): acquired by the next periodic search (frame
  // 11, after that frame's tracked markers), reported from frame 12 on.
  seq.movers.push_back({.id = 9, .x = C.x() + 1.0, .y = C.y() - 0.5, .from = 8});
  constexpr int kFrames = 16;
  TempDir dir;
  std::vector<std::vector<ips::sim::MarkerTruth>> truths(kFrames);
  std::vector<std::vector<std::uint8_t>> jpegs(kFrames);
  for (int f = 0; f < kFrames; ++f) {
    jpegs[static_cast<std::size_t>(f)] = seq.jpeg(f, truths[static_cast<std::size_t>(f)]);
    char name[32];
    std::snprintf(name, sizeof name, "f%03d.jpg", f);
    std::ofstream(dir.path / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(jpegs[static_cast<std::size_t>(f)].data()),
               static_cast<std::streamsize>(jpegs[static_cast<std::size_t>(f)].size()));
  }
  // The same directory through two sources: one hands the JPEGs over, one decodes them.
  ips::FileSource deferred({.path = dir.path.string(), .fps = 0, .loop = false, .preload = true, .phase_s = {}});
  ips::FileSource decoded({.path = dir.path.string(), .fps = 0, .loop = false, .preload = true, .phase_s = {}});
  ASSERT_TRUE(deferred.defer_decode(true));
  deferred.open();
  decoded.open();
  auto on_frames = read_all(deferred, kFrames);
  auto off_frames = read_all(decoded, kFrames);
  ips::TrackerOptions off;
  off.enabled = false;
  ips::TrackedFrameDetector tracking({}, {}, 1), full({}, off, 1);
  const ips::CameraModel& cam = r.camera().model;
  ips::JpegDecoder reference;
  int compared = 0;
  for (int f = 0; f < kFrames; ++f) {
    const auto i = static_cast<std::size_t>(f);
    ASSERT_EQ(on_frames[i].jpeg, jpegs[i]) << "frame " << f << ": the JPEG as stored";
    ASSERT_TRUE(off_frames[i].jpeg.empty());
    // The web view asks for the whole image on frame 7 (a tracked frame).
    std::vector<ips::MarkerDetection> on, reference_found;
    ASSERT_TRUE(tracking.detect(on_frames[i], &cam, f == 7, on)) << tracking.error();
    // As the daemon does: the markers of the frame go out, then the search for new ones.
    EXPECT_EQ(tracking.acquisition_pending(), f == 5 || f == 11) << "frame " << f;
    ASSERT_TRUE(tracking.acquire(on_frames[i], &cam)) << tracking.error();
    ASSERT_TRUE(full.detect(off_frames[i], &cam, false, reference_found)) << full.error();
    if (f == 7) {
      cv::Mat whole;
      ASSERT_TRUE(reference.decode_gray(jpegs[i], whole));
      EXPECT_EQ(cv::norm(whole, on_frames[i].gray, cv::NORM_INF), 0.0);
    }
    expect_true_markers(reference_found, truths[i], f);
    // Tracking may report a newly appeared marker later (within the period + 1), never otherwise.
    const bool acquiring = f >= 8 && f < 8 + 6 + 1;
    ASSERT_EQ(on.size() + ((acquiring && !find(on, 9)) ? 1 : 0), reference_found.size()) << "frame " << f;
    if (f >= 12) {
      EXPECT_NE(find(on, 9), nullptr) << "frame " << f << ": the search after frame 11 acquired it";
    }
    for (const auto& d : on) {
      const auto* ref = find(reference_found, d.id);
      ASSERT_NE(ref, nullptr) << "frame " << f << " marker " << d.id;
      for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_NEAR(d.corners_px[k].x, ref->corners_px[k].x, 0.05) << "frame " << f << " marker " << d.id;
        EXPECT_NEAR(d.corners_px[k].y, ref->corners_px[k].y, 0.05) << "frame " << f << " marker " << d.id;
      }
      // The positions published from them (ipsd: locate_marker, then the camera's mapper).
      const auto p_on = ips::locate_marker(d, cam, 0.20).p_cam;
      const auto p_ref = ips::locate_marker(*ref, cam, 0.20).p_cam;
      EXPECT_LT((p_on - p_ref).norm(), 1e-3) << "frame " << f << " marker " << d.id;
      ++compared;
    }
  }
  EXPECT_GE(compared, kFrames * 3 + 2);
  // Tracked frames were decoded in their ROIs only: whole decodes are the full search of frame
  // 0 (nothing tracked yet), the periodic searches after the ROIs of frames 5 and 11 (period
  // 6, phase 1) and the web view's frame 7.
  const auto& dc = tracking.decode_counters();
  EXPECT_EQ(tracking.tracker_counters().full_searches, 3u);
  EXPECT_EQ(tracking.tracker_counters().acquisitions, 2u);
  EXPECT_EQ(tracking.tracker_counters().acquired, 1u);  // marker 9
  EXPECT_EQ(dc.whole, 4u);
  EXPECT_EQ(dc.regions, static_cast<std::uint64_t>(kFrames - 2));
  EXPECT_EQ(tracking.tracker_counters().fallbacks, 0u);
  EXPECT_EQ(full.decode_counters().whole + full.decode_counters().regions, 0u);  // its source decoded

  // A corrupt frame: reported, nothing found, the tracks kept (the next frame is still tracked).
  ips::Frame bad;
  bad.jpeg = jpegs[0];
  bad.jpeg.resize(bad.jpeg.size() / 4);  // ends above the ROIs
  std::vector<ips::MarkerDetection> none;
  EXPECT_FALSE(tracking.detect(bad, &cam, false, none));
  EXPECT_TRUE(none.empty());
  EXPECT_NE(tracking.error().find("corrupt JPEG"), std::string::npos) << tracking.error();
}

}  // namespace
