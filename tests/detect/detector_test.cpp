// The detector + depth formula against the simulator's exact truth (the "done means").
#include "ips/detect/detector.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/aruco.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/core/error.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/sim/renderer.h"

namespace {

using ips::sim::CameraRenderer;
using ips::sim::MarkerPose;
using ips::sim::PlacedMarker;
using ips::sim::Scene;
using ips::sim::SceneMarker;

const std::filesystem::path kScene = std::filesystem::path(IPS_CONFIG_DIR) / "scenes/ou2023.yaml";

Scene scene_without_markers(const std::string& dictionary = "DICT_4X4_100", unsigned floor_seed = 1) {
  Scene s = Scene::load(kScene);
  s.markers.clear();
  s.dictionary = dictionary;
  s.floor.seed = floor_seed;
  s.render.noise_sigma = 2.0;
  s.render.jpeg_quality = 90;
  return s;
}

// Renders, JPEG-compresses at q90 and decodes back to greyscale, like a camera frame.
cv::Mat camera_frame(const CameraRenderer& r, const std::vector<PlacedMarker>& markers, std::uint64_t index) {
  cv::Mat gray;
  r.render_markers(markers, gray, index);
  ips::JpegDecoder decoder;
  cv::Mat decoded;
  EXPECT_TRUE(decoder.decode_gray(ips::sim::encode_jpeg(gray, 90, true), decoded));
  return decoded;
}

// Random non-overlapping markers of edge `length`, fully visible in the camera.
std::vector<PlacedMarker> random_markers(const CameraRenderer& r, std::mt19937& rng, int n, double length,
                                         double spread_x, double spread_y, double max_height) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<PlacedMarker> out;
  const auto& C = r.camera().position;
  for (int tries = 0; static_cast<int>(out.size()) < n && tries < 2000; ++tries) {
    SceneMarker m;
    m.id = static_cast<int>(rng() % 100);
    m.length = length;
    const MarkerPose p{C.x() + (u(rng) - 0.5) * spread_x, C.y() + (u(rng) - 0.5) * spread_y, u(rng) * max_height,
                       u(rng) * 2 * std::numbers::pi};
    bool ok = r.truth_of(m, p).visible;
    for (const auto& o : out) {
      ok = ok && o.marker.id != m.id && std::hypot(o.poses[0].x - p.x, o.poses[0].y - p.y) > 1.6 * length + 0.05;
    }
    if (ok) out.push_back({m, {p}});
  }
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Red camera, 20 cm markers ~2.1 m below (heights 0-3 cm), noise sigma 2, JPEG q90.
TEST(Detector, FindsEveryMarkerWithExactCornersAndCameraCoordinates) {
  const Scene scene = scene_without_markers();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const ips::CameraModel& cam = r.camera().model;
  ips::Detector detector;
  std::mt19937 rng(7);
  std::vector<double> errs, errs_no_model;
  int markers = 0;
  for (int f = 0; f < 12; ++f) {
    const auto placed = random_markers(r, rng, 5, 0.20, 3.2, 1.9, 0.03);
    const cv::Mat frame = camera_frame(r, placed, static_cast<std::uint64_t>(f));
    const auto found = detector.detect(frame, &cam);
    const auto found_no_model = detector.detect(frame);
    EXPECT_EQ(found.size(), placed.size()) << "frame " << f;  // all found, nothing else
    for (const auto& pm : placed) {
      ++markers;
      const auto truth = r.truth_of(pm.marker, pm.poses[0]);
      const auto it = std::find_if(found.begin(), found.end(), [&](const auto& d) { return d.id == pm.marker.id; });
      ASSERT_NE(it, found.end()) << "marker " << pm.marker.id << " missed in frame " << f;
      for (std::size_t i = 0; i < 4; ++i) {
        errs.push_back(
            std::hypot(it->corners_px[i].x - truth.corners_px[i].x, it->corners_px[i].y - truth.corners_px[i].y));
      }
      const auto obs = ips::locate_marker(*it, cam, pm.marker.length);
      EXPECT_NEAR(obs.p_cam.x(), truth.formula.p_cam.x(), 0.01);
      EXPECT_NEAR(obs.p_cam.y(), truth.formula.p_cam.y(), 0.01);
      EXPECT_NEAR(obs.p_cam.z(), truth.formula.p_cam.z(), 0.02);
      EXPECT_NEAR(std::remainder(obs.yaw - truth.formula.yaw, 2 * std::numbers::pi), 0.0, std::numbers::pi / 180);
      // The formula's truth itself is close to the geometric centre (sanity of the truth).
      EXPECT_NEAR(truth.formula.p_cam.z(), truth.centre_cam.z(), 0.05);
      const auto it2 = std::find_if(found_no_model.begin(), found_no_model.end(),
                                    [&](const auto& d) { return d.id == pm.marker.id; });
      ASSERT_NE(it2, found_no_model.end());
      for (std::size_t i = 0; i < 4; ++i) {
        errs_no_model.push_back(
            std::hypot(it2->corners_px[i].x - truth.corners_px[i].x, it2->corners_px[i].y - truth.corners_px[i].y));
      }
    }
  }
  EXPECT_GE(markers, 50);
  EXPECT_LT(*std::max_element(errs.begin(), errs.end()), 0.3);
  EXPECT_LT(median(errs), 0.15);
  // Without the camera model the edges are fitted as parabolas in pixels: as good in the
  // median, a little worse near the image border where fisheye edges curve most.
  EXPECT_LT(*std::max_element(errs_no_model.begin(), errs_no_model.end()), 0.6);
  EXPECT_LT(median(errs_no_model), 0.15);
}

// ~40 px and ~200 px wide markers (7.5 cm and 40 cm at ~2.1 m).
TEST(Detector, SmallAndLargeMarkers) {
  const Scene scene = scene_without_markers();
  const CameraRenderer r(scene, scene.camera_index("red"));
  ips::Detector detector;
  std::mt19937 rng(11);
  for (const double length : {0.075, 0.40}) {
    SCOPED_TRACE(length);
    std::vector<double> errs;
    for (int f = 0; f < 4; ++f) {
      const auto placed = random_markers(r, rng, 4, length, 2.4, 1.4, 0.0);
      const auto found =
          detector.detect(camera_frame(r, placed, 500 + static_cast<std::uint64_t>(f)), &r.camera().model);
      EXPECT_EQ(found.size(), placed.size());
      for (const auto& pm : placed) {
        const auto truth = r.truth_of(pm.marker, pm.poses[0]);
        const double width =
            std::hypot(truth.corners_px[1].x - truth.corners_px[0].x, truth.corners_px[1].y - truth.corners_px[0].y);
        EXPECT_TRUE(length < 0.1 ? width < 50 : width > 150) << width;
        for (const auto& d : found) {
          if (d.id != pm.marker.id) continue;
          for (std::size_t i = 0; i < 4; ++i) {
            errs.push_back(
                std::hypot(d.corners_px[i].x - truth.corners_px[i].x, d.corners_px[i].y - truth.corners_px[i].y));
          }
        }
      }
    }
    ASSERT_FALSE(errs.empty());
    EXPECT_LT(*std::max_element(errs.begin(), errs.end()), 0.3);
  }
}

// Against OpenCV's default-parameter detectMarkers on the same frames (docs/perception.md, "Detection"):
// - markers of 24-35 px (7.5 cm over the whole image, squeezed by the fisheye towards the
//   edge): found with the default settings (automatic scale and smallest marker);
// - dim, low-contrast frames (paper 60, ink 30 grey levels before a 35 % vignette, a 50 %
//   lighting gradient, noise sigma 5, JPEG q70): `threshold_windows: [9, 19]`.
// Counts: markers found of those placed; nothing else may be reported.
struct Found {
  int placed = 0, ours = 0, reference = 0, extra = 0;
};
Found compare_with_default_detector(Scene scene, const ips::DetectorOptions& options, double length,
                                    std::uint32_t seed) {
  const CameraRenderer r(scene, scene.camera_index("red"));
  ips::Detector detector(options);
  auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100);
  const auto params = cv::aruco::DetectorParameters::create();
  std::mt19937 rng(seed);
  Found n;
  for (int f = 0; f < 10; ++f) {
    const auto placed = random_markers(r, rng, 6, length, 3.6, 2.0, 0.2);
    cv::Mat gray;
    r.render_markers(placed, gray, 900 + static_cast<std::uint64_t>(f));
    cv::Mat frame;
    ips::JpegDecoder decoder;
    EXPECT_TRUE(decoder.decode_gray(ips::sim::encode_jpeg(gray, scene.render.jpeg_quality, true), frame));
    const auto ours = detector.detect(frame, &r.camera().model);
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(frame, dict, corners, ids, params);
    for (const auto& pm : placed) {
      ++n.placed;
      n.ours += std::any_of(ours.begin(), ours.end(), [&](const auto& d) { return d.id == pm.marker.id; });
      n.reference += std::count(ids.begin(), ids.end(), pm.marker.id) > 0;
    }
    for (const auto& d : ours)
      n.extra += std::none_of(placed.begin(), placed.end(), [&](const auto& pm) { return pm.marker.id == d.id; });
  }
  return n;
}

TEST(Detector, SmallMarkersAreAllFoundWithDefaultSettings) {
  const Found n = compare_with_default_detector(scene_without_markers(), {}, 0.075, 21);
  std::printf("[ detect  ] 7.5 cm markers: %d placed, reference %d, ours (defaults) %d\n", n.placed, n.reference,
              n.ours);
  EXPECT_GE(n.placed, 50);
  EXPECT_EQ(n.ours, n.placed);
  EXPECT_EQ(n.extra, 0);
  // The automatic plan at 1080p: candidate search at half scale down to 24 px markers.
  const auto plan = ips::plan_detection({}, cv::Size(1920, 1080));
  EXPECT_EQ(plan.scale, 2);
  EXPECT_DOUBLE_EQ(plan.min_marker_px, 24);
  EXPECT_FALSE(plan.full_resolution_pass);
}

// The automatic plan (hand-computed): smallest marker max(16, side / 80), scale the largest
// integer keeping it >= 12 px; explicit values are kept, a full-resolution pass added when
// the explicit scale cannot see the smallest marker.
TEST(Detector, PlanFollowsImageSizeAndSmallestMarker) {
  struct Case {
    cv::Size size;
    double min_marker_px;
    int detect_scale;
    double want_min;
    int want_scale;
    bool want_fine;
  };
  for (const Case& c : {Case{{640, 480}, 0, 0, 16, 1, false}, Case{{1280, 960}, 0, 0, 16, 1, false},
                        Case{{1920, 1080}, 0, 0, 24, 2, false}, Case{{3840, 2160}, 0, 0, 48, 4, false},
                        Case{{1920, 1080}, 40, 0, 40, 3, false}, Case{{1920, 1080}, 0, 1, 24, 1, false},
                        Case{{1920, 1080}, 0, 3, 24, 3, true}, Case{{320, 240}, 0, 2, 16, 2, true}}) {
    ips::DetectorOptions o;
    o.min_marker_px = c.min_marker_px;
    o.detect_scale = c.detect_scale;
    const auto plan = ips::plan_detection(o, c.size);
    SCOPED_TRACE(std::to_string(c.size.width) + "x" + std::to_string(c.size.height));
    EXPECT_DOUBLE_EQ(plan.min_marker_px, c.want_min);
    EXPECT_EQ(plan.scale, c.want_scale);
    EXPECT_EQ(plan.full_resolution_pass, c.want_fine);
  }
}

// An explicit scale too coarse for the smallest marker adds a full-resolution pass for the
// small ones (multi-scale): the same markers as the automatic plan.
TEST(Detector, ExplicitCoarseScaleSearchesSmallMarkersAtFullResolution) {
  ips::DetectorOptions coarse;
  coarse.detect_scale = 4;
  const auto plan = ips::plan_detection(coarse, cv::Size(1920, 1080));
  EXPECT_TRUE(plan.full_resolution_pass);
  const Found n = compare_with_default_detector(scene_without_markers(), coarse, 0.075, 21);
  EXPECT_EQ(n.ours, n.placed);
  EXPECT_EQ(n.extra, 0);
}

// Detection in a region of interest (the tracking use): the markers inside it, with the
// corners a full-frame search gives them.
TEST(Detector, RegionOfInterestGivesTheFullFrameCorners) {
  const Scene scene = scene_without_markers();
  const CameraRenderer r(scene, scene.camera_index("red"));
  std::mt19937 rng(31);
  const auto placed = random_markers(r, rng, 5, 0.15, 3.2, 1.9, 0.1);
  const cv::Mat frame = camera_frame(r, placed, 77);
  ips::Detector detector;
  const auto full = detector.detect(frame, &r.camera().model);
  ASSERT_EQ(full.size(), placed.size());
  for (const auto& m : full) {
    double x0 = 1e9, y0 = 1e9, x1 = 0, y1 = 0;
    for (const auto& c : m.corners_px) {
      x0 = std::min(x0, c.x), y0 = std::min(y0, c.y), x1 = std::max(x1, c.x), y1 = std::max(y1, c.y);
    }
    const double margin = 0.5 * (x1 - x0);
    const cv::Rect roi(static_cast<int>(x0 - margin), static_cast<int>(y0 - margin),
                       static_cast<int>(x1 - x0 + 2 * margin), static_cast<int>(y1 - y0 + 2 * margin));
    const auto in_roi = detector.detect(frame, roi, &r.camera().model);
    ASSERT_EQ(in_roi.size(), 1u) << "marker " << m.id;
    EXPECT_EQ(in_roi[0].id, m.id);
    for (std::size_t k = 0; k < 4; ++k) {
      EXPECT_NEAR(in_roi[0].corners_px[k].x, m.corners_px[k].x, 0.05);
      EXPECT_NEAR(in_roi[0].corners_px[k].y, m.corners_px[k].y, 0.05);
    }
  }
  EXPECT_TRUE(detector.detect(frame, cv::Rect(-50, -50, 40, 40)).empty());  // outside: nothing
}

TEST(Detector, DimLowContrastFramesWithTwoThresholdWindowsMatchTheDefaultDetector) {
  Scene dim = scene_without_markers();
  dim.render.white = 60;
  dim.render.black = 30;
  dim.render.gradient = 0.5;
  dim.render.noise_sigma = 5;
  dim.render.jpeg_quality = 70;
  dim.floor.grey = 55;
  ips::DetectorOptions two;
  two.threshold_windows = {9, 19};
  const Found n = compare_with_default_detector(dim, two, 0.20, 22);
  std::printf("[ detect  ] dim frames: %d placed, reference %d, ours with windows {9, 19} %d\n", n.placed, n.reference,
              n.ours);
  EXPECT_GE(n.placed, 50);
  EXPECT_GE(n.ours, n.reference);
  EXPECT_EQ(n.extra, 0);
}

// True if the 6x6 marker's pattern contains a DICT_4X4_100 marker: a black-bordered 6x6-cell
// sub-square whose inner bits are a 4x4 code (then "detecting" it would be right).
bool contains_4x4_marker(int id_6x6) {
  const cv::Mat p = ips::sim::marker_pattern("DICT_6X6_250", id_6x6);  // 8x8 cells
  auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100);
  for (int oy = 0; oy <= 2; ++oy) {
    for (int ox = 0; ox <= 2; ++ox) {
      const cv::Mat sub = p(cv::Rect(ox, oy, 6, 6));
      const int border_white = cv::countNonZero(sub) - cv::countNonZero(sub(cv::Rect(1, 1, 4, 4)));
      if (border_white > 0) continue;
      int idx = 0, rotation = 0;
      if (dict->identify(sub(cv::Rect(1, 1, 4, 4)).clone(), idx, rotation, 0.6)) return true;
    }
  }
  return false;
}

// 100 frames without any marker of the detector's dictionary: 50 of bare floor (three
// cameras, so three floor views), 50 with 6x6 markers of another dictionary as distractors
// (black-bordered squares full of bits, the hardest thing to reject), leaving out the few
// 6x6 patterns that contain a genuine 4x4 marker.
TEST(Detector, NoFalsePositivesOnMarkerFreeFrames) {
  ips::Detector detector;
  int frames = 0;
  std::size_t false_positives = 0;
  {
    const Scene scene = scene_without_markers("DICT_4X4_100", 3);
    for (const char* name : {"red", "white", "black"}) {
      const CameraRenderer r(scene, scene.camera_index(name));
      for (int f = 0; f < (name[0] == 'r' ? 18 : 16); ++f, ++frames) {
        const auto found =
            detector.detect(camera_frame(r, {}, 1000 + static_cast<std::uint64_t>(f)), &r.camera().model);
        false_positives += found.size();
      }
    }
  }
  {
    const Scene scene = scene_without_markers("DICT_6X6_250", 4);
    const CameraRenderer r(scene, scene.camera_index("white"));
    std::mt19937 rng(5);
    for (int f = 0; f < 50; ++f, ++frames) {
      auto placed = random_markers(r, rng, 6, 0.15 + 0.05 * (f % 3), 3.2, 1.9, 0.2);
      for (auto& p : placed) {
        while (contains_4x4_marker(p.marker.id)) p.marker.id = (p.marker.id + 101) % 250;
      }
      const auto found =
          detector.detect(camera_frame(r, placed, 2000 + static_cast<std::uint64_t>(f)), &r.camera().model);
      false_positives += found.size();
    }
  }
  EXPECT_EQ(frames, 100);
  EXPECT_EQ(false_positives, 0u);
}

TEST(Detector, OtherDictionaries) {
  const Scene scene = scene_without_markers("DICT_5X5_50");
  const CameraRenderer r(scene, scene.camera_index("red"));
  std::mt19937 rng(3);
  auto placed = random_markers(r, rng, 3, 0.2, 2.4, 1.4, 0.1);
  for (auto& p : placed) p.marker.id %= 50;
  ips::DetectorOptions o;
  o.dictionary = "DICT_5X5_50";
  EXPECT_EQ(ips::Detector(o).detect(camera_frame(r, placed, 9), &r.camera().model).size(), placed.size());
  // The 4x4 detector sees none of them.
  EXPECT_EQ(ips::Detector().detect(camera_frame(r, placed, 9)).size(), 0u);
}

TEST(Detector, RejectsBadInputAndOptions) {
  ips::Detector detector;
  EXPECT_THROW(detector.detect(cv::Mat()), ips::InputError);
  EXPECT_THROW(detector.detect(cv::Mat(100, 100, CV_8UC3, cv::Scalar(0))), ips::InputError);
  EXPECT_TRUE(detector.detect(cv::Mat(100, 100, CV_8UC1, cv::Scalar(128))).empty());
  ips::DetectorOptions o;
  o.dictionary = "DICT_4X4_101";
  try {
    ips::Detector bad(o);
    ADD_FAILURE();
  } catch (const ips::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("DICT_4X4_101"), std::string::npos);
  }
  o = {};
  o.threshold_windows = {8};
  EXPECT_THROW(ips::Detector{o}, ips::InputError);
  o = {};
  o.detect_scale = -1;
  EXPECT_THROW(ips::Detector{o}, ips::InputError);
  o = {};
  o.min_marker_px = -3;
  EXPECT_THROW(ips::Detector{o}, ips::InputError);
}

}  // namespace
