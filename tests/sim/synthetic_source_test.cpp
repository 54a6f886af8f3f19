#include "ips/sim/synthetic_source.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"

namespace {

std::shared_ptr<const ips::sim::Scene> published_scene() {
  static auto scene = std::make_shared<const ips::sim::Scene>(
      ips::sim::Scene::load(std::filesystem::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml"));
  return scene;
}

TEST(SyntheticSource, SourcesOfOneSceneAgreeOnSceneTimeAndTruth) {
  const std::int64_t epoch = ips::monotonic_ns();
  ips::sim::SyntheticSourceOptions a{.camera = "red", .fps = 20, .realtime = false, .epoch_mono_ns = epoch};
  ips::sim::SyntheticSourceOptions b = a;
  b.camera = "white";
  ips::sim::SyntheticSource red(published_scene(), a), white(published_scene(), b);
  red.open();
  white.open();
  ips::Frame fr, fw;
  ips::Detector detector;
  int seen = 0;
  for (int k = 0; k < 4; ++k) {
    ASSERT_EQ(red.read(fr, std::chrono::milliseconds(100)), ips::FrameSource::ReadStatus::kFrame);
    ASSERT_EQ(white.read(fw, std::chrono::milliseconds(100)), ips::FrameSource::ReadStatus::kFrame);
    EXPECT_EQ(fr.sequence, static_cast<std::uint64_t>(k));
    EXPECT_EQ(fr.t_mono_ns, epoch + k * 50'000'000LL);
    EXPECT_EQ(fr.t_mono_ns, fw.t_mono_ns);
    EXPECT_NEAR(red.scene_time(fr.t_mono_ns), k * 0.05, 1e-12);
    EXPECT_DOUBLE_EQ(red.scene_time(fr.t_mono_ns), white.scene_time(fw.t_mono_ns));
    EXPECT_EQ(fr.gray.size(), cv::Size(1920, 1080));
    EXPECT_FALSE(red.last_jpeg().empty());
    // The frame shows the scene at its capture time: every visible marker is detected where
    // the truth says, within a fraction of a pixel.
    const auto truth = red.truth(fr.t_mono_ns);
    const auto found = detector.detect(fr.gray);
    for (const auto& t : truth) {
      const auto pose = published_scene()->marker_pose(t.id, k * 0.05);
      EXPECT_DOUBLE_EQ(t.pose.x, pose.x);
      if (!t.visible) continue;
      ++seen;
      bool matched = false;
      for (const auto& d : found) {
        if (d.id != t.id) continue;
        matched = true;
        for (std::size_t i = 0; i < 4; ++i) {
          EXPECT_LT(std::hypot(d.corners_px[i].x - t.corners_px[i].x, d.corners_px[i].y - t.corners_px[i].y), 0.5);
        }
      }
      EXPECT_TRUE(matched) << "marker " << t.id << " not found at frame " << k;
    }
  }
  EXPECT_GE(seen, 4);
}

TEST(SyntheticSource, RealtimePacingTimesOutBeforeTheFirstFrameIsDue) {
  ips::sim::SyntheticSourceOptions o{
      .camera = "black", .fps = 30, .realtime = true, .epoch_mono_ns = ips::monotonic_ns() + 60'000'000'000LL};
  ips::sim::SyntheticSource src(published_scene(), o);
  src.open();
  ips::Frame f;
  EXPECT_EQ(src.read(f, std::chrono::milliseconds(1)), ips::FrameSource::ReadStatus::kTimeout);
}

TEST(SyntheticSource, RealtimeFramesAreNotEarlyAndEndAfterMaxFrames) {
  ips::sim::SyntheticSourceOptions o{.camera = "red", .fps = 50, .realtime = true, .max_frames = 2};
  ips::sim::SyntheticSource src(published_scene(), o);
  src.open();
  ips::Frame f;
  for (int k = 0; k < 2; ++k) {
    ASSERT_EQ(src.read(f, std::chrono::milliseconds(1000)), ips::FrameSource::ReadStatus::kFrame);
    EXPECT_LE(f.t_mono_ns, ips::monotonic_ns());  // never delivered before its capture time
    EXPECT_NEAR(static_cast<double>(f.t_real_ns - f.t_mono_ns), static_cast<double>(ips::realtime_minus_monotonic_ns()),
                5e6);
  }
  EXPECT_EQ(src.read(f, std::chrono::milliseconds(10)), ips::FrameSource::ReadStatus::kEnd);
}

TEST(SyntheticSource, RenderAheadDeliversAfterTheTransportDelayTheSameFrames) {
  // Frames rendered ahead on the source's own thread are handed over at capture + delay, and
  // are the very frames the synchronous path renders (same scene time, same noise, same JPEG).
  const std::int64_t epoch = ips::monotonic_ns() + 300'000'000;  // leaves time to render ahead
  ips::sim::SyntheticSourceOptions o{
      .camera = "white", .fps = 20, .realtime = true, .epoch_mono_ns = epoch, .max_frames = 3};
  o.render_ahead = true;
  o.transport_delay_ns = 30'000'000;
  o.phase_ns = 7'000'000;
  ips::sim::SyntheticSourceOptions sync = o;
  sync.realtime = false;
  sync.render_ahead = false;
  sync.max_frames = 0;
  ips::sim::SyntheticSource ahead(published_scene(), o), reference(published_scene(), sync);
  ahead.open();
  reference.open();
  ips::Frame f, g;
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(ahead.read(f, std::chrono::milliseconds(5000)), ips::FrameSource::ReadStatus::kFrame);
    const std::int64_t returned = ips::monotonic_ns();
    do {  // the same frame (the renderer may skip one on a loaded machine, as a camera drops)
      ASSERT_EQ(reference.read(g, std::chrono::milliseconds(0)), ips::FrameSource::ReadStatus::kFrame);
    } while (g.sequence < f.sequence);
    EXPECT_EQ(f.sequence, g.sequence);
    EXPECT_EQ(f.t_mono_ns, epoch + 7'000'000 + static_cast<std::int64_t>(f.sequence) * 50'000'000);
    EXPECT_EQ(f.t_mono_ns, g.t_mono_ns);
    EXPECT_GE(f.t_delivered_ns, f.t_mono_ns + 30'000'000);
    EXPECT_GE(returned, f.t_delivered_ns);
    EXPECT_EQ(cv::norm(f.gray, g.gray, cv::NORM_INF), 0.0) << "frame " << f.sequence;
  }
  EXPECT_EQ(ahead.read(f, std::chrono::milliseconds(10)), ips::FrameSource::ReadStatus::kEnd);
}

TEST(SyntheticSource, RejectsUnknownCameraAndBadRate) {
  EXPECT_THROW(ips::sim::SyntheticSource(published_scene(), {.camera = "green"}), ips::InputError);
  EXPECT_THROW(ips::sim::SyntheticSource(published_scene(), {.camera = "red", .fps = 0}), ips::InputError);
  ips::sim::SyntheticSource src(published_scene(), {.camera = "red"});
  ips::Frame f;
  EXPECT_THROW(src.read(f, std::chrono::milliseconds(1)), ips::SourceError);
}

}  // namespace
