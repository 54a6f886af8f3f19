// ips::V4L2Source against the emulated V4L2 device (tests/capture/v4l2_emulator.cpp), run in
// a child process (tests/capture/capture_driver.cpp) with the emulator preloaded.
#include "ips/capture/v4l2_source.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "emu_control.h"
#include "emu_harness.h"
#include "ips/core/error.h"

namespace {

using ips::test::field;
using ips::test::lines_starting;

// A distinct, textured test card per frame index k (textured so a JPEG is not trivially small).
cv::Mat card(int w, int h, int k) {
  cv::Mat img(h, w, CV_8UC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img.at<uchar>(y, x) = static_cast<uchar>(30 + 40 * k + ((x / 8 + y / 8) % 2) * 60 + (x * 40) / w);
  return img;
}

class EmulatedCamera : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(dir_ / "frames");
    control_ = dir_ / "cam0.conf";
  }

  // Renders `n` JPEG frames of w x h into the frames directory.
  void write_frames(int w, int h, int n = 4) {
    for (int k = 0; k < n; ++k) {
      cards_.push_back(card(w, h, k));
      cv::imwrite(dir_ / ("frames/f" + std::to_string(k) + ".jpg"), cards_.back(), {cv::IMWRITE_JPEG_QUALITY, 95});
    }
  }

  void configure(ips::test::EmuSettings settings) {
    settings.emplace("frames", dir_ / "frames");
    settings.emplace("fps", "100");
    ips::test::write_emu_control(control_, settings);
  }

  ips::test::ChildResult run(std::vector<std::string> args) {
    args.insert(args.begin(), IPS_CAPTURE_DRIVER);
    return ips::test::run_emulated(args, {{kDevice, control_}}, dir_.str());
  }

  static constexpr const char* kDevice = "/dev/video-emu0";
  ips::test::TempDir dir_;
  std::string control_;
  std::vector<cv::Mat> cards_;
};

struct FrameLine {
  std::uint64_t seq;
  std::int64_t mono, real, read_mono, offset;
  int width, height;
};

std::vector<FrameLine> parse_frames(const std::string& out) {
  std::vector<FrameLine> frames;
  for (const auto& l : lines_starting(out, "frame "))
    frames.push_back({std::stoull(field(l, "seq")), std::stoll(field(l, "mono")), std::stoll(field(l, "real")),
                      std::stoll(field(l, "read_mono")), std::stoll(field(l, "offset")), std::stoi(field(l, "width")),
                      std::stoi(field(l, "height"))});
  return frames;
}

std::uint64_t stat_of(const std::string& out, const std::string& key) {
  const auto lines = lines_starting(out, "stats ");
  return lines.empty() ? ~0ull : std::stoull(field(lines.back(), key));
}

// The emulator itself behaves like a V4L2 driver (else the other tests prove little).
TEST_F(EmulatedCamera, EmulatorFollowsV4l2BufferSemantics) {
  configure({{"formats", "YUYV"}, {"sizes", "160x120"}, {"fps", "2"}});  // first frame 0.5 s after STREAMON
  const auto r = run({"raw", "--device", kDevice});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("poll_before_streamon=POLLERR\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dqbuf_early=EAGAIN\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("select=1 isset=1\n"), std::string::npos) << r.out;
  const auto frame = lines_starting(r.out, "seq=");
  ASSERT_EQ(frame.size(), 1u) << r.out;
  EXPECT_EQ(field(frame[0], "seq"), "0");
  EXPECT_EQ(field(frame[0], "monotonic"), "1");
  EXPECT_EQ(field(frame[0], "bytesused"), std::to_string(160 * 2 * 120));
  EXPECT_EQ(field(frame[0], "y32"), "7");  // Y(x=3, y=2) of frame 0 = 3 + 2*2
  // Frame 0 completes one period after STREAMON, which happened just before t_on.
  const double after = std::stod(field(frame[0], "ts_after_streamon_ns"));
  EXPECT_LE(after, 0.5e9);
  EXPECT_GT(after, 0.25e9);  // loose: the driver may be descheduled after STREAMON
}

TEST_F(EmulatedCamera, MjpegFramesCarrySizeSequenceAndDriverTimestamps) {
  write_frames(640, 480);
  configure({{"sizes", "1920x1080,640x480"}});
  const auto r = run({"capture", "--device", kDevice, "--width", "640", "--height", "480", "--fps", "100", "--frames",
                      "12", "--dump-dir", dir_.str()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto granted = lines_starting(r.out, "granted ");
  ASSERT_EQ(granted.size(), 1u);
  EXPECT_EQ(field(granted[0], "format"), "MJPEG");
  EXPECT_EQ(field(granted[0], "fps"), "100.000");
  EXPECT_EQ(field(granted[0], "buffers"), "4");
  EXPECT_EQ(field(granted[0], "driver"), "ips-v4l2-emu");

  const auto frames = parse_frames(r.out);
  ASSERT_EQ(frames.size(), 12u);
  std::uint64_t gaps = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const FrameLine& f = frames[i];
    EXPECT_EQ(f.width, 640);
    EXPECT_EQ(f.height, 480);
    EXPECT_LE(f.mono, f.read_mono) << "a capture time in the future";
    // realtime = monotonic + the clock offset (sampled within a second of the frame).
    EXPECT_NEAR(static_cast<double>(f.real - f.mono), static_cast<double>(f.offset), 1e6);
    if (i > 0) {
      const FrameLine& p = frames[i - 1];
      ASSERT_GT(f.seq, p.seq);
      gaps += f.seq - p.seq - 1;
      // The emulator's frame n completes at t0 + (n+1) * 10 ms; V4L2 carries microseconds.
      EXPECT_NEAR(static_cast<double>(f.mono - p.mono), 10e6 * static_cast<double>(f.seq - p.seq), 1e3);
    }
    // The pixels are the card the emulator served for this sequence number.
    const cv::Mat got = cv::imread(dir_ / ("frame_" + std::to_string(f.seq) + ".png"), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(got.empty());
    cv::Mat diff;
    cv::absdiff(got, cards_[f.seq % cards_.size()], diff);
    EXPECT_LT(cv::mean(diff)[0], 3.0) << "frame " << f.seq;
  }
  EXPECT_EQ(frames.front().seq, 0u);
  EXPECT_EQ(stat_of(r.out, "drops"), gaps);
  EXPECT_EQ(stat_of(r.out, "corrupt"), 0u);
}

TEST_F(EmulatedCamera, FallsBackToYuyvAndTakesTheLumaPlane) {
  // No MJPEG; padded lines so that bytesperline != 2 * width.
  configure({{"formats", "YUYV"}, {"sizes", "320x240"}, {"yuyv_padding", "64"}});
  const auto r = run(
      {"capture", "--device", kDevice, "--width", "320", "--height", "240", "--frames", "3", "--dump-dir", dir_.str()});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(field(lines_starting(r.out, "granted ").at(0), "format"), "YUYV");
  EXPECT_NE(r.err.find("MJPEG not offered, falling back to YUYV"), std::string::npos) << r.err;
  const auto frames = parse_frames(r.out);
  ASSERT_EQ(frames.size(), 3u);
  for (const auto& f : frames) {
    const cv::Mat got = cv::imread(dir_ / ("frame_" + std::to_string(f.seq) + ".png"), cv::IMREAD_GRAYSCALE);
    ASSERT_EQ(got.size(), cv::Size(320, 240));
    int wrong = 0;
    for (int y = 0; y < got.rows; ++y)
      for (int x = 0; x < got.cols; ++x) wrong += got.at<uchar>(y, x) != static_cast<uchar>((x + 2 * y + f.seq) & 255);
    EXPECT_EQ(wrong, 0) << "frame " << f.seq;
  }
}

TEST_F(EmulatedCamera, ReportsTheSizeTheDeviceGranted) {
  write_frames(640, 480, 2);
  configure({{"grant", "640x480"}});
  const auto r =
      run({"capture", "--device", kDevice, "--width", "1920", "--height", "1080", "--frames", "2", "--scale", "2"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto granted = lines_starting(r.out, "granted ").at(0);
  EXPECT_EQ(field(granted, "width"), "640");
  EXPECT_EQ(field(granted, "height"), "480");
  EXPECT_NE(r.err.find("asked for 1920x1080, the device granted 640x480"), std::string::npos) << r.err;
  for (const auto& f : parse_frames(r.out)) {  // decoded at half scale in the DCT domain
    EXPECT_EQ(f.width, 320);
    EXPECT_EQ(f.height, 240);
  }
}

TEST_F(EmulatedCamera, CorruptJpegsAreSkippedAndCounted) {
  write_frames(320, 240);
  configure({{"sizes", "320x240"}, {"corrupt_every", "3"}});
  const auto r = run({"capture", "--device", kDevice, "--width", "320", "--height", "240", "--frames", "10"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto frames = parse_frames(r.out);
  ASSERT_EQ(frames.size(), 10u);
  for (const auto& f : frames) EXPECT_NE(f.seq % 3, 2u) << "a truncated frame was delivered";
  const std::uint64_t corrupt = stat_of(r.out, "corrupt");
  EXPECT_GE(corrupt, 4u);  // sequences 2, 5, 8, 11 at least precede the 10th good frame
  EXPECT_EQ(corrupt, lines_starting(r.out, "corrupt").size());
  // Every sequence number up to the last one is a frame, a corrupt frame or a driver drop.
  EXPECT_EQ(stat_of(r.out, "frames") + corrupt + stat_of(r.out, "drops"), frames.back().seq + 1);
}

TEST_F(EmulatedCamera, SequenceGapsCountAsDriverDrops) {
  configure({{"formats", "YUYV"}, {"sizes", "160x120"}, {"drop_every", "4"}});
  const auto r = run({"capture", "--device", kDevice, "--width", "160", "--height", "120", "--frames", "9"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto frames = parse_frames(r.out);
  ASSERT_EQ(frames.size(), 9u);
  for (const auto& f : frames) EXPECT_NE(f.seq % 4, 3u);
  EXPECT_GE(stat_of(r.out, "drops"), 2u);  // 3 and 7 at least lie before the 9th frame
  EXPECT_EQ(stat_of(r.out, "frames") + stat_of(r.out, "drops"), frames.back().seq + 1);
}

TEST_F(EmulatedCamera, ControlsAreSetAndAdjustmentsReported) {
  configure({{"formats", "YUYV"}, {"sizes", "160x120"}});
  // 0.5 s exceeds the device's maximum 2047 x 100 us; gain 300 exceeds 255.
  const auto r = run({"capture", "--device", kDevice, "--width", "160", "--height", "120", "--frames", "1",
                      "--exposure", "0.5", "--gain", "300", "--autofocus", "0", "--power-line", "50"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto granted = lines_starting(r.out, "granted ").at(0);
  EXPECT_EQ(field(granted, "exposure_s"), "0.2047");
  EXPECT_EQ(field(granted, "gain"), "255");
  EXPECT_EQ(field(granted, "autofocus"), "0");
  EXPECT_EQ(field(granted, "power_line_hz"), "50");
  EXPECT_NE(r.err.find("control gain: asked for 300, the device set 255"), std::string::npos) << r.err;
}

TEST_F(EmulatedCamera, UnsupportedControlIsAWarningNotAnError) {
  configure({{"formats", "YUYV"}, {"sizes", "160x120"}, {"unsupported_controls", "gain,focus_auto"}});
  const auto r = run({"capture", "--device", kDevice, "--width", "160", "--height", "120", "--frames", "1", "--gain",
                      "10", "--autofocus", "0", "--exposure", "0.01"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto granted = lines_starting(r.out, "granted ").at(0);
  EXPECT_EQ(field(granted, "gain"), "");
  EXPECT_EQ(field(granted, "exposure_s"), "0.0100");
  EXPECT_NE(r.err.find("control gain=10 not supported"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("control focus_auto=0 not supported"), std::string::npos) << r.err;
}

TEST_F(EmulatedCamera, UnplugThrowsSourceErrorAndReplugReopensWithoutLeaks) {
  configure({{"formats", "YUYV"}, {"sizes", "160x120"}, {"fps", "200"}});
  const auto r = run(
      {"unplug", "--device", kDevice, "--width", "160", "--height", "120", "--control", control_, "--cycles", "100"});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto line = [&](const std::string& key) {
    const auto l = lines_starting(r.out, key + "=");
    return l.empty() ? std::string() : l[0];
  };
  EXPECT_NE(field(line("read_error"), "read_error").find("unplugged"), std::string::npos) << r.out;
  EXPECT_EQ(field(line("read_error"), "open_after"), "0");  // read() closed it before throwing
  EXPECT_NE(field(line("open_error"), "open_error").find("No such file or directory"), std::string::npos) << r.out;
  EXPECT_EQ(field(line("replugged_frames"), "opens"), "101");
  // While streaming: the emulator's own view of the buffers + the 4 mmap'ed by the source.
  EXPECT_EQ(field(line("maps_open"), "maps_open"), "5");
  const std::string counts = line("fds_before");
  ASSERT_FALSE(counts.empty()) << r.out;
  EXPECT_EQ(field(counts, "fds_after"), field(counts, "fds_before"));
  EXPECT_EQ(field(counts, "maps_before"), "0");
  EXPECT_EQ(field(counts, "maps_after"), "0");
}

TEST_F(EmulatedCamera, UnpluggingOneCameraLeavesTheOtherStreaming) {
  write_frames(320, 240, 2);
  configure({{"sizes", "320x240"}});
  const std::string control1 = dir_ / "cam1.conf";
  ips::test::write_emu_control(control1, {{"formats", "YUYV"}, {"sizes", "320x240"}, {"fps", "100"}});
  const auto r =
      ips::test::run_emulated({IPS_CAPTURE_DRIVER, "two", "--device", kDevice, "--device2", "/dev/video-emu1",
                               "--width", "320", "--height", "240", "--control", control_},
                              {{kDevice, control_}, {"/dev/video-emu1", control1}}, dir_.str());
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const auto during = lines_starting(r.out, "during_unplug ");
  ASSERT_EQ(during.size(), 1u) << r.out;
  EXPECT_EQ(field(during[0], "cam0"), "0");
  EXPECT_GE(std::stoi(field(during[0], "cam1")), 20);
  const auto resumed = lines_starting(r.out, "resumed=");
  ASSERT_EQ(resumed.size(), 1u) << r.out;
  EXPECT_EQ(field(resumed[0], "resumed"), "1");
  EXPECT_EQ(field(resumed[0], "cam0_opens"), "2");
  EXPECT_EQ(field(resumed[0], "cam1_opens"), "1");
}

TEST(V4L2Source, OpeningAMissingDeviceThrowsSourceErrorNamingIt) {
  ips::V4L2Options options;
  options.device = "/nonexistent/video7";
  ips::V4L2Source source(options);
  try {
    source.open();
    FAIL() << "open() succeeded";
  } catch (const ips::SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/video7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(source.is_open());
  source.close();  // idempotent
}

TEST(V4L2Source, ANonV4l2FileIsRefused) {
  ips::V4L2Options options;
  options.device = "/dev/null";
  ips::V4L2Source source(options);
  EXPECT_THROW(source.open(), ips::SourceError);
  EXPECT_FALSE(source.is_open());
}

TEST(V4L2Options, InvalidValuesAreInputErrors) {
  auto with = [](auto change) {
    ips::V4L2Options o;
    o.device = "/dev/video0";
    change(o);
    return o;
  };
  EXPECT_NO_THROW(with([](auto&) {}).validate());
  EXPECT_THROW(with([](auto& o) { o.buffer_count = 2; }).validate(), ips::InputError);
  EXPECT_THROW(with([](auto& o) { o.decode_scale = 3; }).validate(), ips::InputError);
  EXPECT_THROW(with([](auto& o) { o.fps = 0; }).validate(), ips::InputError);
  EXPECT_THROW(with([](auto& o) { o.device.clear(); }).validate(), ips::InputError);
  EXPECT_THROW(with([](auto& o) { o.controls.power_line_hz = 55; }).validate(), ips::InputError);
  EXPECT_THROW(with([](auto& o) {
                 o.controls.exposure_s = 0.01;
                 o.controls.auto_exposure = true;
               }).validate(),
               ips::InputError);
}

}  // namespace
