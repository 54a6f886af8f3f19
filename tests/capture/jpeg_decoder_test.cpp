#include "ips/capture/jpeg_decoder.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {

// A colour test card whose luminance we can check against OpenCV's own conversion.
cv::Mat make_card(int w, int h) {
  cv::Mat bgr(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(x * 255 / w), static_cast<uchar>(y * 255 / h),
                                          static_cast<uchar>(((x / 16 + y / 16) % 2) * 200));
  return bgr;
}

std::vector<std::uint8_t> encode(const cv::Mat& img, int quality = 95) {
  std::vector<std::uint8_t> buf;
  cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, quality});
  return buf;
}

TEST(JpegDecoder, GreyMatchesLuminanceOfColourDecode) {
  const cv::Mat card = make_card(320, 240);
  const auto jpeg = encode(card);
  ips::JpegDecoder decoder;
  cv::Mat gray;
  ASSERT_TRUE(decoder.decode_gray(jpeg, gray)) << decoder.error();
  ASSERT_EQ(gray.size(), cv::Size(320, 240));
  ASSERT_EQ(gray.type(), CV_8UC1);
  cv::Mat reference;
  cv::cvtColor(cv::imdecode(jpeg, cv::IMREAD_COLOR), reference, cv::COLOR_BGR2GRAY);
  cv::Mat diff;
  cv::absdiff(gray, reference, diff);
  // Y plane vs re-derived luminance from decoded RGB: rounding and fast DCT only.
  EXPECT_LE(cv::mean(diff)[0], 1.5);
}

TEST(JpegDecoder, ScaledDecodeHasCeilSize) {
  const auto jpeg = encode(make_card(322, 241));
  ips::JpegDecoder decoder;
  cv::Mat gray;
  ASSERT_TRUE(decoder.decode_gray(jpeg, gray, 2));
  EXPECT_EQ(gray.size(), cv::Size(161, 121));
  ASSERT_TRUE(decoder.decode_gray(jpeg, gray, 4));
  EXPECT_EQ(gray.size(), cv::Size(81, 61));
}

TEST(JpegDecoder, ReusesBufferForSameSize) {
  const auto jpeg = encode(make_card(64, 48));
  ips::JpegDecoder decoder;
  cv::Mat gray;
  ASSERT_TRUE(decoder.decode_gray(jpeg, gray));
  const uchar* data = gray.data;
  ASSERT_TRUE(decoder.decode_gray(jpeg, gray));
  EXPECT_EQ(gray.data, data);
}

TEST(JpegDecoder, TruncatedAndGarbageAreRejected) {
  auto jpeg = encode(make_card(320, 240));
  ips::JpegDecoder decoder;
  cv::Mat gray;
  std::vector<std::uint8_t> truncated(jpeg.begin(), jpeg.begin() + static_cast<long>(jpeg.size() / 2));
  EXPECT_FALSE(decoder.decode_gray(truncated, gray));
  EXPECT_FALSE(decoder.error().empty());
  std::vector<std::uint8_t> garbage(1000, 0x5a);
  EXPECT_FALSE(decoder.decode_gray(garbage, gray));
  EXPECT_FALSE(decoder.decode_gray(std::span<const std::uint8_t>{}, gray));
  // The decoder keeps working after a failure.
  EXPECT_TRUE(decoder.decode_gray(jpeg, gray)) << decoder.error();
}

}  // namespace
