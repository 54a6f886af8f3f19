#include "ips/file_source.h"

#include <gtest/gtest.h>

#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "emu_harness.h"
#include "ips/clock.h"
#include "ips/error.h"

namespace {

using Status = ips::FrameSource::ReadStatus;
using std::chrono::milliseconds;

cv::Mat flat(int value) { return cv::Mat(48, 64, CV_8UC1, cv::Scalar(value)); }

// Reads until a frame (or kEnd) arrives; nothing but kTimeout in between.
Status next(ips::FrameSource& s, ips::Frame& f) {
  for (;;) {
    const Status st = s.read(f, milliseconds(500));
    if (st != Status::kTimeout) return st;
  }
}

TEST(FileSource, DirectoryLoopsInNameOrderPacedAndTimestamped) {
  ips::test::TempDir dir;
  // Written out of order: playback follows the names.
  cv::imwrite(dir / "b.png", flat(20));
  cv::imwrite(dir / "a.png", flat(10));
  cv::imwrite(dir / "c.png", flat(30));
  std::ofstream(dir / "notes.txt") << "not an image";
  ips::FileSource source({dir.str(), 200.0, true});
  const std::int64_t t_open = ips::monotonic_ns();
  source.open();
  ips::Frame f;
  std::int64_t previous = 0;
  for (int k = 0; k < 7; ++k) {
    const std::int64_t before = ips::monotonic_ns();
    ASSERT_EQ(next(source, f), Status::kFrame);
    const std::int64_t after = ips::monotonic_ns();
    EXPECT_EQ(f.sequence, static_cast<std::uint64_t>(k));
    EXPECT_EQ(f.gray.type(), CV_8UC1);
    EXPECT_EQ(f.gray.at<uchar>(5, 5), 10 * (k % 3 + 1)) << "frame " << k;
    EXPECT_GE(f.t_mono_ns, before);
    EXPECT_LE(f.t_mono_ns, after);
    EXPECT_GT(f.t_mono_ns, previous);
    // Paced at 200 fps: frame k is not delivered before open + k * 5 ms.
    EXPECT_GE(f.t_mono_ns - t_open, k * 5'000'000LL);
    EXPECT_NEAR(static_cast<double>(f.t_real_ns - f.t_mono_ns),
                static_cast<double>(ips::realtime_minus_monotonic_ns()), 5e6);
    previous = f.t_mono_ns;
  }
}

TEST(FileSource, EndsWhenNotLoopingAndConvertsColourToGrey) {
  ips::test::TempDir dir;
  const cv::Mat colour(10, 10, CV_8UC3, cv::Scalar(200, 100, 50));  // BGR
  cv::imwrite(dir / "0.png", colour);
  ips::FileSource source({dir.str(), 0.0, false});
  source.open();
  ips::Frame f;
  ASSERT_EQ(source.read(f, milliseconds(0)), Status::kFrame);
  // ITU-R BT.601 luma: 0.114 B + 0.587 G + 0.299 R.
  EXPECT_NEAR(f.gray.at<uchar>(0, 0), 0.114 * 200 + 0.587 * 100 + 0.299 * 50, 1.0);
  EXPECT_EQ(source.read(f, milliseconds(0)), Status::kEnd);
}

TEST(FileSource, UnreadableImageIsCorruptAndSkipped) {
  ips::test::TempDir dir;
  cv::imwrite(dir / "0.png", flat(10));
  std::ofstream(dir / "1.jpg") << "garbage, not a JPEG";
  cv::imwrite(dir / "2.png", flat(30));
  ips::FileSource source({dir.str(), 0.0, false});
  source.open();
  ips::Frame f;
  EXPECT_EQ(source.read(f, milliseconds(0)), Status::kFrame);
  EXPECT_EQ(source.read(f, milliseconds(0)), Status::kCorrupt);
  ASSERT_EQ(source.read(f, milliseconds(0)), Status::kFrame);
  EXPECT_EQ(f.gray.at<uchar>(0, 0), 30);
  EXPECT_EQ(f.sequence, 1u);
}

TEST(FileSource, ReturnsTimeoutWhenTheNextFrameIsNotDue) {
  ips::test::TempDir dir;
  cv::imwrite(dir / "0.png", flat(10));
  ips::FileSource source({dir.str(), 1.0, true});  // one frame per second
  source.open();
  ips::Frame f;
  EXPECT_EQ(source.read(f, milliseconds(0)), Status::kFrame);  // due at open
  EXPECT_EQ(source.read(f, milliseconds(5)), Status::kTimeout);
}

TEST(FileSource, VideoFileLoops) {
  ips::test::TempDir dir;
  const std::string video = dir / "clip.avi";
  {
    cv::VideoWriter writer(video, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           10, cv::Size(64, 48));
    ASSERT_TRUE(writer.isOpened());
    for (int v : {40, 120, 200}) {
      cv::Mat bgr;
      cv::cvtColor(flat(v), bgr, cv::COLOR_GRAY2BGR);
      writer.write(bgr);
    }
  }
  ips::FileSource source({video, 0.0, true});
  source.open();
  ips::Frame f;
  for (int k = 0; k < 7; ++k) {
    ASSERT_EQ(next(source, f), Status::kFrame) << "frame " << k;
    ASSERT_EQ(f.gray.size(), cv::Size(64, 48));
    EXPECT_NEAR(f.gray.at<uchar>(20, 20),
                (std::array{40, 120, 200})[static_cast<std::size_t>(k % 3)], 3)
        << k;
  }
}

TEST(FileSource, MissingOrEmptyPathThrowsSourceError) {
  ips::test::TempDir dir;
  ips::FileSource missing({dir / "nope.avi", 30.0, true});
  try {
    missing.open();
    FAIL();
  } catch (const ips::SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("nope.avi"), std::string::npos) << e.what();
  }
  ips::FileSource empty({dir.str(), 30.0, true});
  EXPECT_THROW(empty.open(), ips::SourceError);
  EXPECT_THROW(ips::FileSource({"", 30.0, true}), ips::InputError);
  EXPECT_THROW(ips::FileSource({dir.str(), -1.0, true}), ips::InputError);
}

}  // namespace
