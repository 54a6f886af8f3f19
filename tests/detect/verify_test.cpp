// The cell verification on markers seen at a grazing angle and blurred (narrow cells lose
// contrast) and on 6x6 markers that a 4x4 search could misread, both synthesised here by
// warping OpenCV's own marker drawing.
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/detect/detector.h"
#include "ips/sim/renderer.h"

namespace {

// A marker of `dictionary` (white quiet zone of one cell) pasted on a mid-grey 640x480
// image through a perspective squeezing it to ~`w` x `h` px (a grazing view), blurred
// with `sigma`, with noise.
cv::Mat oblique_marker(int dictionary, int id, double w, double h, double sigma, unsigned seed) {
  const auto dict = cv::aruco::getPredefinedDictionary(dictionary);
  const int cells = dict->markerSize + 2;
  const int cell = 20;
  cv::Mat marker;
  cv::aruco::drawMarker(dict, id, cells * cell, marker, 1);
  cv::Mat sheet(marker.rows + 2 * cell, marker.cols + 2 * cell, CV_8UC1, cv::Scalar(255));
  marker.copyTo(sheet(cv::Rect(cell, cell, marker.cols, marker.rows)));
  // Ink 40, paper 200: like a print under room light.
  sheet.convertTo(sheet, CV_8UC1, 160.0 / 255.0, 40);
  const float s = static_cast<float>(sheet.cols);
  const float pad = static_cast<float>(cell) / static_cast<float>(marker.cols);  // quiet zone
  const float W = static_cast<float>(w) * (1 + 2 * pad), H = static_cast<float>(h) * (1 + 2 * pad);
  const cv::Point2f o(300, 220);
  // The far edge shorter than the near one: a plane seen obliquely.
  const std::vector<cv::Point2f> src{{0, 0}, {s, 0}, {s, s}, {0, s}};
  const std::vector<cv::Point2f> dst{o + cv::Point2f(0.12f * W, 0), o + cv::Point2f(0.88f * W, 0),
                                     o + cv::Point2f(W, H), o + cv::Point2f(0, H)};
  cv::Mat image(480, 640, CV_8UC1, cv::Scalar(110));
  cv::warpPerspective(sheet, image, cv::getPerspectiveTransform(src, dst), image.size(), cv::INTER_AREA,
                      cv::BORDER_TRANSPARENT);
  cv::GaussianBlur(image, image, cv::Size(), sigma);
  cv::Mat noise(image.size(), CV_16SC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::Mat out;
  image.convertTo(out, CV_16SC1);
  out += noise;
  out.convertTo(out, CV_8UC1);
  return out;
}

bool found_id(const std::vector<ips::MarkerDetection>& found, int id) {
  for (const auto& d : found) {
    if (d.id == id) return true;
  }
  return false;
}

// Genuine 4x4 markers squeezed to ~75 x 40 px (and narrower) and blurred: every one that
// OpenCV's default detector reads is kept; some of them have more ambiguous cells than
// max_ambiguous_cells and would be dropped without the code check (min_clear_margin 64
// turns it off: no other code can differ in 64 of 16 cells).
TEST(Verify, KeepsGenuineObliqueBlurredMarkers) {
  ips::Detector detector;
  ips::DetectorOptions strict_options;
  strict_options.min_clear_margin = 64;
  ips::Detector strict(strict_options);
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100);
  int opencv = 0, ours = 0, strict_found = 0, cases = 0;
  // Left out: 24 px high with sigma 2.2 (blur wider than half the 4 px cell height). OpenCV
  // reads id 3 there from corners 2-4 px (up to a cell) off the truth; ips's edge fit is as
  // far off (its profiles never reach the black level of the blurred 4 px border), the grid
  // then reads part of the border white, and the verification drops the marker (docs/perception.md).
  for (const double h : {40.0, 30.0, 24.0}) {
    for (const double sigma : {1.0, 1.6, 2.2}) {
      if (h < 25 && sigma > 2) continue;
      for (const int id : {3, 17, 42, 88}) {
        const cv::Mat image =
            oblique_marker(cv::aruco::DICT_4X4_100, id, 75, h, sigma, static_cast<unsigned>(id + 100 * cases));
        ++cases;
        std::vector<std::vector<cv::Point2f>> corners;
        std::vector<int> ids;
        cv::aruco::detectMarkers(image, dict, corners, ids);
        const auto found = detector.detect(image);
        for (const auto& d : found) EXPECT_EQ(d.id, id) << "h " << h << " sigma " << sigma;
        const bool ref = !ids.empty() && ids[0] == id;
        opencv += ref;
        ours += found_id(found, id);
        strict_found += found_id(strict.detect(image), id);
        if (ref) {
          EXPECT_TRUE(found_id(found, id)) << "id " << id << " h " << h << " sigma " << sigma;
        }
      }
    }
  }
  std::printf("[ verify  ] %d oblique blurred markers: OpenCV %d, ips %d, ips without the code check %d\n", cases,
              opencv, ours, strict_found);
  EXPECT_GT(opencv, cases / 2);
  EXPECT_LT(strict_found, ours);  // the code check is what keeps some of them
}

// True if the 6x6 marker's pattern holds a genuine DICT_4X4_100 marker (a black-bordered
// 6x6-cell sub-square with a 4x4 code): finding that one would be right.
bool contains_4x4_marker(int id_6x6) {
  const cv::Mat p = ips::sim::marker_pattern("DICT_6X6_250", id_6x6);  // 8x8 cells
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100);
  for (int oy = 0; oy <= 2; ++oy) {
    for (int ox = 0; ox <= 2; ++ox) {
      const cv::Mat sub = p(cv::Rect(ox, oy, 6, 6));
      if (cv::countNonZero(sub) != cv::countNonZero(sub(cv::Rect(1, 1, 4, 4)))) continue;
      int idx = 0, rotation = 0;
      if (dict->identify(sub(cv::Rect(1, 1, 4, 4)).clone(), idx, rotation, 0.6)) return true;
    }
  }
  return false;
}

// 6x6 markers under the same views, searched as DICT_4X4_100: nothing (their 8-cell grid
// read as 6 cells leaves cells straddling printed ones).
TEST(Verify, RefusesSixBySixMarkersReadAsFourByFour) {
  ips::Detector detector;
  int false_positives = 0, cases = 0;
  for (const double h : {75.0, 40.0, 30.0}) {
    for (const double sigma : {0.6, 1.0, 1.6, 2.2}) {
      for (int id = 0; id < 250; id += 7) {
        if (contains_4x4_marker(id)) continue;
        const cv::Mat image =
            oblique_marker(cv::aruco::DICT_6X6_250, id, 75, h, sigma, static_cast<unsigned>(id + 1000 * cases));
        ++cases;
        false_positives += static_cast<int>(detector.detect(image).size());
      }
    }
  }
  std::printf("[ verify  ] %d views of 6x6 markers searched as 4x4: %d found\n", cases, false_positives);
  EXPECT_GE(cases, 12 * 30);
  EXPECT_EQ(false_positives, 0);
}

}  // namespace
