// Restart markers: the layout read from a JPEG's headers (against values worked out by hand from
// the encoder's settings), and the rows cut out at them (decoded by OpenCV's own decoder, an
// independent one, against the rows of the whole frame).
#include "ips/capture/jpeg_restart.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/capture/jpeg_region_decoder.h"
#include "ips/core/error.h"
#include "ips/sim/renderer.h"

namespace {

// A frame with detail in every block, so that every MCU has its own coefficients.
cv::Mat card(int w, int h) {
  cv::Mat g(h, w, CV_8UC1);
  cv::randu(g, 0, 255);
  cv::GaussianBlur(g, g, cv::Size(5, 5), 1.5);
  return g;
}

std::vector<std::uint8_t> encode(const cv::Mat& img, int restart_mcus, int quality = 90) {
  std::vector<std::uint8_t> buf;
  cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, quality, cv::IMWRITE_JPEG_RST_INTERVAL, restart_mcus});
  return buf;
}

TEST(JpegRestartLayout, ReadsTheIntervalAndWhereRowsCanBeEntered) {
  const cv::Mat grey = card(1920, 1080);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  ips::JpegRestartLayout l;
  std::string why;
  // OpenCV writes colour as 4:2:0: 16 x 16 MCUs, 120 per row, 68 rows (1080 / 16 = 67.5).
  ASSERT_TRUE(ips::read_jpeg_restart_layout(encode(colour, 120), l, why)) << why;
  EXPECT_EQ(l.width, 1920);
  EXPECT_EQ(l.height, 1080);
  EXPECT_EQ(l.mcu_width, 16);
  EXPECT_EQ(l.mcu_height, 16);
  EXPECT_EQ(l.mcus_per_row, 120);
  EXPECT_EQ(l.mcu_rows, 68);
  EXPECT_EQ(l.restart_interval, 120);
  EXPECT_EQ(l.entry_rows, 1);
  // Every 40 MCUs: three per row, each row still starts one. Every 240: every other row. Every
  // 50: rows r with 120 r a multiple of 50, i.e. every 5th row (gcd 10).
  ASSERT_TRUE(ips::read_jpeg_restart_layout(encode(colour, 40), l, why));
  EXPECT_EQ(l.entry_rows, 1);
  ASSERT_TRUE(ips::read_jpeg_restart_layout(encode(colour, 240), l, why));
  EXPECT_EQ(l.entry_rows, 2);
  ASSERT_TRUE(ips::read_jpeg_restart_layout(encode(colour, 50), l, why));
  EXPECT_EQ(l.entry_rows, 5);
  // None: read, with no entry points.
  ASSERT_TRUE(ips::read_jpeg_restart_layout(encode(colour, 0), l, why));
  EXPECT_EQ(l.restart_interval, 0);
  EXPECT_EQ(l.entry_rows, 0);
  // One component: 8 x 8 MCUs.
  ASSERT_TRUE(ips::read_jpeg_restart_layout(encode(grey, 240), l, why));
  EXPECT_EQ(l.mcu_width, 8);
  EXPECT_EQ(l.mcus_per_row, 240);
  EXPECT_EQ(l.mcu_rows, 135);
  EXPECT_EQ(l.entry_rows, 1);
  // The simulator's camera frames: restart_rows MCU rows per interval.
  ASSERT_TRUE(ips::read_jpeg_restart_layout(ips::sim::encode_jpeg(grey, 90, true, 2), l, why)) << why;
  EXPECT_EQ(l.mcu_height, 16);
  EXPECT_EQ(l.restart_interval, 240);
  EXPECT_EQ(l.entry_rows, 2);
}

// The simulator's frames with restart markers (libjpeg's own API) are the frames it makes
// without (TurboJPEG's): the same pixels once decoded, only cut into intervals.
TEST(JpegRestartLayout, SimulatedFramesWithRestartsDecodeAsThoseWithout) {
  const cv::Mat grey = card(640, 480);
  ips::JpegDecoder decoder;
  for (bool colour : {true, false}) {
    cv::Mat plain, restarted;
    ASSERT_TRUE(decoder.decode_gray(ips::sim::encode_jpeg(grey, 85, colour, 0), plain));
    ASSERT_TRUE(decoder.decode_gray(ips::sim::encode_jpeg(grey, 85, colour, 1), restarted));
    EXPECT_EQ(cv::norm(plain, restarted, cv::NORM_INF), 0) << (colour ? "colour" : "grey");
  }
  EXPECT_THROW(ips::sim::encode_jpeg(grey, 85, true, 256), ips::InputError);
}

TEST(JpegRestartLayout, RefusesWhatCannotBeEnteredAndSaysWhy) {
  ips::JpegRestartLayout l;
  std::string why;
  const std::vector<std::uint8_t> garbage(100, 0x55);
  EXPECT_FALSE(ips::read_jpeg_restart_layout(garbage, l, why));
  EXPECT_NE(why.find("not a JPEG"), std::string::npos) << why;
  std::vector<std::uint8_t> progressive;
  cv::imencode(".jpg", card(64, 48), progressive, {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  EXPECT_FALSE(ips::read_jpeg_restart_layout(progressive, l, why));
  EXPECT_EQ(why, "progressive JPEG");
  auto jpeg = encode(card(64, 48), 8);
  for (std::size_t cut : {std::size_t{3}, std::size_t{20}, std::size_t{100}}) {
    EXPECT_FALSE(ips::read_jpeg_restart_layout(std::span(jpeg.data(), cut), l, why)) << cut;
    EXPECT_FALSE(why.empty());
  }
}

TEST(JpegRowCutter, CutRowsDecodeToTheWholeFramesRows) {
  const cv::Mat grey = card(1920, 1080);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  for (int interval : {120, 40, 240}) {
    SCOPED_TRACE(interval);
    const auto jpeg = encode(colour, interval);
    ips::JpegRestartLayout l;
    std::string why;
    ASSERT_TRUE(ips::read_jpeg_restart_layout(jpeg, l, why));
    const cv::Mat whole = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    // Two bands in the middle and the last rows (the partial bottom MCU row).
    const std::vector<std::pair<int, int>> ranges = {{10, 14}, {30, 32}, {66, 68}};
    ips::JpegRowCutter cutter;
    std::vector<std::uint8_t> out;
    ASSERT_TRUE(cutter.cut(jpeg, l, ranges, out, why)) << why;
    EXPECT_LT(out.size(), jpeg.size() / 4);
    const cv::Mat part = cv::imdecode(out, cv::IMREAD_GRAYSCALE);
    ASSERT_EQ(part.cols, 1920);
    ASSERT_EQ(part.rows, 4 * 16 + 2 * 16 + (1080 - 66 * 16));
    int y = 0;
    for (const auto& [first, last] : ranges) {
      const int rows = std::min(last * 16, 1080) - first * 16;
      EXPECT_EQ(cv::norm(part.rowRange(y, y + rows), whole.rowRange(first * 16, first * 16 + rows), cv::NORM_INF), 0)
          << "MCU rows " << first << ".." << last;
      y += rows;
    }
  }
}

TEST(JpegRowCutter, RefusesRowsBetweenMarkersAndDamagedScans) {
  const auto jpeg = encode(card(320, 240), 40);  // grey: 8 x 8 MCUs, 40 = one row
  ips::JpegRestartLayout l;
  std::string why;
  ASSERT_TRUE(ips::read_jpeg_restart_layout(jpeg, l, why));
  ASSERT_EQ(l.mcus_per_row, 40);
  ASSERT_EQ(l.entry_rows, 1);
  ips::JpegRowCutter cutter;
  std::vector<std::uint8_t> out;
  EXPECT_FALSE(cutter.cut(jpeg, l, {{5, 3}}, out, why));
  EXPECT_FALSE(cutter.cut(jpeg, l, {{2, 4}, {3, 6}}, out, why));
  EXPECT_FALSE(cutter.cut(jpeg, l, {{2, 31}}, out, why));
  // A restart marker renumbered: out of sequence.
  auto damaged = jpeg;
  int seen = 0;
  for (std::size_t i = l.scan_offset; i + 1 < damaged.size(); ++i) {
    if (damaged[i] == 0xFF && damaged[i + 1] >= 0xD0 && damaged[i + 1] <= 0xD7 && ++seen == 3) {
      damaged[i + 1] = 0xD5;
      break;
    }
  }
  ASSERT_EQ(seen, 3);
  EXPECT_FALSE(cutter.cut(damaged, l, {{10, 12}}, out, why));
  EXPECT_NE(why.find("out of sequence"), std::string::npos) << why;
  // Rows above the damage are still cut; the region decoder falls back to the whole stream
  // for the frame and reports the damage libjpeg finds there.
  EXPECT_TRUE(cutter.cut(damaged, l, {{1, 2}}, out, why)) << why;
  ips::JpegRegionDecoder decoder;
  cv::Mat gray;
  EXPECT_FALSE(decoder.decode(damaged, gray, {cv::Rect(0, 160, 64, 16)}));
  EXPECT_FALSE(decoder.error().empty());
  EXPECT_EQ(decoder.restart_fallbacks(), 1u);
  // Truncated inside the scan: no end-of-image marker where the last rows are.
  const std::span<const std::uint8_t> truncated(jpeg.data(), jpeg.size() - 200);
  EXPECT_FALSE(cutter.cut(truncated, l, {{28, 30}}, out, why));
  EXPECT_NE(why.find("end-of-image"), std::string::npos) << why;
}

}  // namespace
