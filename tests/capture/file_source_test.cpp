#include "ips/capture/file_source.h"

#include <iterator>
#include <thread>

#include <gtest/gtest.h>

#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "emu_harness.h"
#include "ips/capture/jpeg_decoder.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"

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
    EXPECT_NEAR(static_cast<double>(f.t_real_ns - f.t_mono_ns), static_cast<double>(ips::realtime_minus_monotonic_ns()),
                5e6);
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

// With a phase, frames are due on the monotonic clock's grid phase + k / fps (unsynchronised
// file cameras): read as soon as due, each frame comes just after a grid point (within 50 ms:
// a margin for a busy machine; without the phase the offset would be anywhere in the 100 ms
// period) and consecutive frames in consecutive periods.
TEST(FileSource, PhasePutsFramesOnTheClocksGrid) {
  ips::test::TempDir dir;
  cv::imwrite(dir / "0.png", flat(10));
  ips::FileSourceOptions o{dir.str(), 10.0, true};
  o.phase_s = 0.037;
  ips::FileSource source(o);
  source.open();
  constexpr std::int64_t kPeriod = 100'000'000, kPhase = 37'000'000;
  ips::Frame f;
  std::int64_t previous_point = -1;
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(source.read(f, milliseconds(500)), Status::kFrame);
    const std::int64_t point = (f.t_mono_ns - kPhase) / kPeriod * kPeriod + kPhase;  // the grid point at or before
    EXPECT_LT(f.t_mono_ns - point, kPeriod / 2) << "frame " << k;
    if (previous_point >= 0) {
      EXPECT_EQ(point - previous_point, kPeriod) << "frame " << k;
    }
    previous_point = point;
  }
  o.phase_s = 1.0;
  EXPECT_THROW(ips::FileSource{o}, ips::InputError);
}

// Virtual time: frames are stamped exactly on the grid from the start instant (k / fps), in
// order, none skipped, handed over at once however slowly they are read or however fast:
// 30 frames of 10 fps (2.9 s of stamps) are read without waiting for them, and a reader that
// dawdles 150 ms per frame still gets every frame, its stamps unchanged.
TEST(FileSource, VirtualTimeStampsEveryFrameOnTheGridWithoutWaiting) {
  ips::test::TempDir dir;
  cv::imwrite(dir / "0.png", flat(10));
  cv::imwrite(dir / "1.png", flat(20));
  ips::FileSourceOptions o{dir.str(), 10.0, true};
  const std::int64_t start = ips::monotonic_ns() + 5'000'000'000;  // in the future: nothing waits for it
  o.virtual_start_ns = start;
  ips::FileSource source(o);
  source.open();
  ips::Frame f;
  const std::int64_t t0 = ips::monotonic_ns();
  for (int k = 0; k < 30; ++k) {
    ASSERT_EQ(source.read(f, milliseconds(0)), Status::kFrame) << "frame " << k;
    EXPECT_EQ(f.t_mono_ns, start + k * 100'000'000LL) << "frame " << k;
    EXPECT_EQ(f.sequence, static_cast<std::uint64_t>(k));
    EXPECT_EQ(f.gray.at<std::uint8_t>(0, 0), k % 2 == 0 ? 10 : 20) << "the files in order";
    if (k >= 27) std::this_thread::sleep_for(milliseconds(150));
  }
  EXPECT_LT(ips::monotonic_ns() - t0, 2'000'000'000) << "the 2.9 s of frames were not waited for";
  ASSERT_EQ(source.read(f, milliseconds(0)), Status::kFrame);
  EXPECT_EQ(f.t_mono_ns, start + 30 * 100'000'000LL) << "a slow reader skips nothing";
  o.fps = 0;  // no frame rate: nothing to stamp the frames with
  EXPECT_THROW(ips::FileSource{o}, ips::InputError);
}

TEST(FileSource, VideoFileLoops) {
  ips::test::TempDir dir;
  const std::string video = dir / "clip.avi";
  {
    cv::VideoWriter writer(video, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10,
                           cv::Size(64, 48));
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
    EXPECT_NEAR(f.gray.at<uchar>(20, 20), (std::array{40, 120, 200})[static_cast<std::size_t>(k % 3)], 3) << k;
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

namespace {

// Replay: a preloaded directory plays the same frames as one read from disk (JPEG
// frames decoded as the daemon decodes MJPEG: libjpeg-turbo's luma, fast IDCT, within a few
// grey levels of OpenCV's decode), keeps playing after the files are deleted (they are in memory), and a
// damaged JPEG is a corrupt frame.
TEST(FileSource, PreloadedDirectoryReplaysFromMemory) {
  ips::test::TempDir dir;
  cv::Mat img(96, 128, CV_8UC1);
  for (int i = 0; i < 3; ++i) {
    cv::randu(img, 0, 255);
    cv::GaussianBlur(img, img, cv::Size(5, 5), 1.5);
    cv::imwrite(dir / ("f" + std::to_string(i) + ".jpg"), img);
  }
  cv::imwrite(dir / "f3.png", flat(77));
  std::ofstream(dir / "f4.jpg", std::ios::binary) << "\xFF\xD8\xFF\xE0 not really a jpeg";
  ips::FileSource disk({dir.str(), 0.0, false});
  ips::FileSourceOptions o{dir.str(), 0.0, true};
  o.preload = true;
  ips::FileSource memory(o);
  disk.open();
  memory.open();
  ips::Frame a, b;
  std::vector<cv::Mat> from_disk;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(next(disk, a), Status::kFrame) << i;
    from_disk.push_back(a.gray.clone());
  }
  std::vector<std::vector<std::uint8_t>> jpegs;
  for (int i = 0; i < 3; ++i) {
    std::ifstream in(dir / ("f" + std::to_string(i) + ".jpg"), std::ios::binary);
    jpegs.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  for (const auto& p : std::filesystem::directory_iterator(dir.str())) std::filesystem::remove(p.path());
  for (int i = 0; i < 4; ++i) {
    a.gray = from_disk[static_cast<std::size_t>(i)];
    ASSERT_EQ(next(memory, b), Status::kFrame) << i;
    ASSERT_EQ(b.gray.type(), CV_8UC1);
    ASSERT_EQ(b.gray.size(), a.gray.size());
    if (i < 3) {  // a JPEG: exactly the daemon's MJPEG decode; OpenCV's (slow IDCT) within a few levels
      cv::Mat expected;
      ASSERT_TRUE(ips::JpegDecoder().decode_gray(jpegs[static_cast<std::size_t>(i)], expected));
      EXPECT_EQ(cv::norm(expected, b.gray, cv::NORM_INF), 0.0) << i;
      EXPECT_LE(cv::norm(a.gray, b.gray, cv::NORM_INF), 8.0) << i;
      EXPECT_LT(cv::norm(a.gray, b.gray, cv::NORM_L1) / static_cast<double>(a.gray.total()), 1.0) << i;
    } else {
      EXPECT_EQ(cv::norm(a.gray, b.gray, cv::NORM_INF), 0.0) << i;  // the PNG, exactly
    }
    EXPECT_EQ(b.sequence, static_cast<std::uint64_t>(i));
  }
  EXPECT_EQ(next(memory, b), Status::kCorrupt);  // f4.jpg
  ASSERT_EQ(next(memory, b), Status::kFrame);    // looped: f0 again, from memory
  EXPECT_EQ(cv::norm(b.gray(cv::Rect(0, 0, 8, 8)), cv::NORM_INF) > 0, true);
  ips::FileSourceOptions bad{dir / "f0.jpg", 30.0, true};
  bad.preload = true;
  EXPECT_THROW(bad.validate(), ips::InputError);
}

}  // namespace
