// Sources made for virtual time (SourceContext::virtual_time, `ips record --virtual-time`):
// a synthetic camera and a file camera share one timeline, frame k of each stamped exactly
// epoch + phase + k / fps and handed over without waiting for the clock; a V4L2 camera is
// refused with an error naming its entry.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "config_scratch.h"
#include "ips/config/source_factory.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace {

class VirtualTimeSources : public ips::test::ConfigScratch {};

TEST_F(VirtualTimeSources, SyntheticAndFileCamerasShareOneExactTimeline) {
  ips::SourceContext context;
  context.synthetic_epoch_mono_ns = ips::monotonic_ns() + 3'000'000'000LL;  // ahead of the clock
  context.virtual_time = true;

  ips::CameraConfig synthetic;
  synthetic.index = 0;
  synthetic.name = "red";
  synthetic.source = ips::SourceKind::kSynthetic;
  synthetic.scene = std::filesystem::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml";
  synthetic.scene_camera = "red";
  synthetic.fps = 10;
  synthetic.phase_s = 0.011;

  cv::imwrite((dir_ / "0.png").string(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(9)));
  ips::CameraConfig file;
  file.index = 1;
  file.name = "replay";
  file.source = ips::SourceKind::kFile;
  file.file.path = dir_.string();
  file.fps = 10;
  file.phase_s = 0.022;

  auto a = ips::make_source_factory(synthetic, context)();
  auto b = ips::make_source_factory(file, context)();
  a->open();
  b->open();
  const std::int64_t t0 = ips::monotonic_ns();
  ips::Frame f;
  for (int k = 0; k < 12; ++k) {
    ASSERT_EQ(a->read(f, std::chrono::milliseconds(0)), ips::FrameSource::ReadStatus::kFrame) << k;
    EXPECT_EQ(f.t_mono_ns, context.synthetic_epoch_mono_ns + 11'000'000 + k * 100'000'000LL) << "synthetic " << k;
    ASSERT_EQ(b->read(f, std::chrono::milliseconds(0)), ips::FrameSource::ReadStatus::kFrame) << k;
    EXPECT_EQ(f.t_mono_ns, context.synthetic_epoch_mono_ns + 22'000'000 + k * 100'000'000LL) << "file " << k;
  }
  // 1.1 s of frames stamped up to 4 s ahead of the clock: none was waited for.
  EXPECT_LT(ips::monotonic_ns() - t0, 3'000'000'000LL);

  ips::CameraConfig v4l2;
  v4l2.index = 2;
  v4l2.name = "ceiling";
  v4l2.source = ips::SourceKind::kV4l2;
  v4l2.v4l2.device = "/dev/video0";
  try {
    (void)ips::make_source_factory(v4l2, context);
    ADD_FAILURE() << "a V4L2 camera on virtual time was accepted";
  } catch (const ips::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras[2]"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("real time only"), std::string::npos) << e.what();
  }
}

}  // namespace
