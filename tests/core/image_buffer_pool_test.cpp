// The image buffer pool (OpenCV's default Mat allocator in ipsd): a freed image buffer is
// handed out again to the next Mat of its size or a little smaller, small Mats never touch
// it, what it keeps is bounded, and Mats made and freed on several threads at once keep
// their contents.
#include "ips/core/image_buffer_pool.h"

#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#if defined(__has_include)
#if __has_include(<sanitizer/asan_interface.h>)
#include <sanitizer/asan_interface.h>
#endif
#endif

namespace {

class ImageBufferPoolTest : public ::testing::Test {
 protected:
  void SetUp() override { ips::install_image_buffer_pool(std::size_t{64} << 20); }
};

TEST_F(ImageBufferPoolTest, AFreedImageBufferIsHandedOutAgain) {
  const auto before = ips::image_buffer_pool_stats();
  cv::Mat a(1080, 1920, CV_8UC1);
  const uchar* data = a.data;
  a.release();
  const auto freed = ips::image_buffer_pool_stats();
  EXPECT_EQ(freed.allocated - before.allocated + freed.reused - before.reused, 1u);
  EXPECT_GE(freed.cached_bytes, std::size_t{1920} * 1080);
  // The same size again, and a slightly smaller image (a marker's region that shrank): the
  // buffer the pool holds.
  cv::Mat b(1080, 1920, CV_8UC1);
  EXPECT_EQ(b.data, data);
  b.release();
  cv::Mat c(1000, 1900, CV_8UC1);
  EXPECT_EQ(c.data, data);
  c.setTo(7);  // the whole buffer it was given is writable
  EXPECT_EQ(cv::countNonZero(c), 1000 * 1900);
  const auto after = ips::image_buffer_pool_stats();
  EXPECT_EQ(after.reused - freed.reused, 2u);
  EXPECT_EQ(after.allocated, freed.allocated);
}

TEST_F(ImageBufferPoolTest, ABufferIsNotHandedToAMuchSmallerOrLargerImage) {
  cv::Mat a(1080, 1920, CV_8UC1);
  const uchar* data = a.data;
  a.release();
  cv::Mat half(540, 960, CV_8UC1);  // a quarter of the size: its own buffer, not the big one
  EXPECT_NE(half.data, data);
  cv::Mat big(1080, 1920, CV_8UC3);  // three times the size
  EXPECT_NE(big.data, data);
}

TEST_F(ImageBufferPoolTest, SmallMatsAndMatsOverTheCallersMemoryAreOpenCVsOwn) {
  const auto before = ips::image_buffer_pool_stats();
  cv::Mat cells(100, 100, CV_8UC1);  // 10 kB: below image size
  std::vector<uchar> mine(640 * 480);
  cv::Mat over(480, 640, CV_8UC1, mine.data());
  cv::Mat copy = over.clone();  // 300 kB: pooled
  const auto after = ips::image_buffer_pool_stats();
  EXPECT_EQ(after.allocated - before.allocated + after.reused - before.reused, 1u);
  EXPECT_EQ(over.data, mine.data());
}

TEST_F(ImageBufferPoolTest, WhatThePoolKeepsIsBounded) {
  ips::install_image_buffer_pool(std::size_t{4} << 20);  // 4 MiB
  const auto before = ips::image_buffer_pool_stats();
  {
    std::vector<cv::Mat> many;
    for (int i = 0; i < 8; ++i) many.emplace_back(1080, 1920, CV_8UC1);  // ~16 MiB at once
  }
  const auto after = ips::image_buffer_pool_stats();
  EXPECT_LE(after.cached_bytes, std::size_t{4} << 20);
  EXPECT_GE(after.released - before.released, 6u);
  ips::install_image_buffer_pool(std::size_t{64} << 20);
}

TEST_F(ImageBufferPoolTest, MatsMadeAndFreedOnSeveralThreadsKeepTheirContents) {
  const auto before = ips::image_buffer_pool_stats();
  std::vector<std::thread> threads;
  std::atomic<int> wrong{0};
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([t, &wrong] {
      std::mt19937 rng(static_cast<unsigned>(t));
      std::uniform_int_distribution<int> side(150, 700);
      std::vector<cv::Mat> held;
      for (int i = 0; i < 400; ++i) {
        cv::Mat m(side(rng), side(rng), CV_8UC1, cv::Scalar(t * 50 + i % 50));
        held.push_back(m);
        if (held.size() > 3) {
          // The oldest must still hold what was written into it.
          const cv::Mat& old = held.front();
          const int value = old.at<uchar>(0, 0);
          if (cv::countNonZero(old != value) != 0) ++wrong;
          held.erase(held.begin());
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(wrong, 0);
  const auto after = ips::image_buffer_pool_stats();
  EXPECT_EQ(after.in_use_bytes, before.in_use_bytes) << "every buffer came back";
  EXPECT_GT(after.reused - before.reused, 1000u) << "most requests were served from the pool";
}

#if defined(__SANITIZE_ADDRESS__) || (defined(__has_feature) && __has_feature(address_sanitizer))
TEST_F(ImageBufferPoolTest, UnderAsanTheSlackAndFreeBuffersAreNotAddressable) {
  cv::Mat a(1000, 1000, CV_8UC1);  // 1e6 bytes in a class of 1,048,576
  const uchar* end = a.data + a.total();
  EXPECT_FALSE(__asan_address_is_poisoned(end - 1));
  EXPECT_TRUE(__asan_address_is_poisoned(end)) << "an overrun past the image is reported";
  const uchar* data = a.data;
  a.release();
  EXPECT_TRUE(__asan_address_is_poisoned(data)) << "a use after free is reported";
}
#endif

}  // namespace
