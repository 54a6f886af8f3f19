// ips's detector on real photographs (tests/data/real_photos: webcams, a phone at an oblique
// angle, ChArUco boards, dim light, negatives of other dictionaries), against OpenCV 4.6's
// default-parameter cv::aruco::detectMarkers on the same image with the same dictionary.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/aruco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/detect/detector.h"

namespace {

const std::filesystem::path kPhotos = std::filesystem::path(IPS_CONFIG_DIR) / ".." / "tests" / "data" / "real_photos";

struct Photo {
  std::string file, dictionary;
};

std::vector<Photo> photos() {
  std::ifstream in(kPhotos / "images.json");
  EXPECT_TRUE(in.good()) << kPhotos / "images.json";
  const auto j = nlohmann::json::parse(in);
  std::vector<Photo> out;
  for (const auto& e : j.at("images")) out.push_back({e.at("file"), e.at("dictionary")});
  return out;
}

// Markers ips finds that OpenCV's default detector does not, each checked by eye on the
// photograph (a black-bordered square with the printed label's id where there is one).
struct Extra {
  const char* file;
  int id;
};
const std::vector<Extra> kCheckedExtras = {};

cv::Point2f centre(const std::vector<cv::Point2f>& q) { return (q[0] + q[1] + q[2] + q[3]) * 0.25f; }

TEST(RealPhotos, FindsEveryMarkerOpenCvFindsWithAgreeingCornersAndNothingElse) {
  const auto list = photos();
  ASSERT_EQ(list.size(), 12u);
  int reference_total = 0, found_total = 0, extra_total = 0;
  std::vector<double> corner_diff;  // ours vs OpenCV's corners + cornerSubPix, px
  for (const auto& p : list) {
    SCOPED_TRACE(p.file);
    const cv::Mat gray = cv::imread((kPhotos / p.file).string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(gray.empty());
    ips::DetectorOptions o;
    o.dictionary = p.dictionary;
    ips::Detector detector(o);
    const auto ours = detector.detect(gray);

    const auto dict = cv::aruco::getPredefinedDictionary(ips::dictionary_id(p.dictionary));
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(gray, dict, corners, ids, cv::aruco::DetectorParameters::create());
    int found = 0, extra = 0;
    std::vector<bool> used(ours.size(), false);
    for (std::size_t i = 0; i < ids.size(); ++i) {
      std::vector<cv::Point2f> sub = corners[i];
      cv::cornerSubPix(gray, sub, cv::Size(3, 3), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 30, 0.001));
      const cv::Point2f c = centre(corners[i]);
      const double side = cv::norm(corners[i][1] - corners[i][0]);
      bool hit = false;
      for (std::size_t k = 0; k < ours.size() && !hit; ++k) {
        const auto& d = ours[k];
        const cv::Point2f dc(
            static_cast<float>((d.corners_px[0].x + d.corners_px[1].x + d.corners_px[2].x + d.corners_px[3].x) / 4),
            static_cast<float>((d.corners_px[0].y + d.corners_px[1].y + d.corners_px[2].y + d.corners_px[3].y) / 4));
        if (d.id != ids[i] || cv::norm(dc - c) > 0.3 * side) continue;
        hit = true;
        used[k] = true;
        for (std::size_t j = 0; j < 4; ++j) {
          const double e = std::hypot(d.corners_px[j].x - sub[j].x, d.corners_px[j].y - sub[j].y);
          corner_diff.push_back(e);
          EXPECT_LT(e, 1.5 + 0.01 * side) << "id " << ids[i] << " corner " << j;
        }
      }
      EXPECT_TRUE(hit) << "missed id " << ids[i] << " at (" << c.x << ", " << c.y << "), " << side << " px";
      found += hit;
    }
    for (std::size_t k = 0; k < ours.size(); ++k) {
      if (used[k]) continue;
      const bool checked = std::any_of(kCheckedExtras.begin(), kCheckedExtras.end(),
                                       [&](const Extra& e) { return p.file == e.file && ours[k].id == e.id; });
      ++extra;
      EXPECT_TRUE(checked) << "id " << ours[k].id << " at (" << ours[k].corners_px[0].x << ", "
                           << ours[k].corners_px[0].y << ") is not found by OpenCV";
    }
    std::printf("[ photos  ] %-30s %4dx%-4d OpenCV %2zu, ips %2zu (of OpenCV's %2d, extra %d)\n", p.file.c_str(),
                gray.cols, gray.rows, ids.size(), ours.size(), found, extra);
    reference_total += static_cast<int>(ids.size());
    found_total += found;
    extra_total += extra;
  }
  std::sort(corner_diff.begin(), corner_diff.end());
  if (!corner_diff.empty()) {
    std::printf(
        "[ photos  ] total: OpenCV %d, ips found %d of them, %d extra; corner difference to "
        "OpenCV+cornerSubPix median %.3f px, p95 %.3f, max %.3f\n",
        reference_total, found_total, extra_total, corner_diff[corner_diff.size() / 2],
        corner_diff[corner_diff.size() * 95 / 100], corner_diff.back());
  }
  EXPECT_EQ(found_total, reference_total);
  EXPECT_EQ(extra_total, 0);
  ASSERT_FALSE(corner_diff.empty());
  EXPECT_LT(corner_diff[corner_diff.size() / 2], 0.5);
}

// `ips locate` on a photograph of any size without intrinsics: a generic pinhole guess,
// said on stderr; the ids and pixel corners are those of the detector.
TEST(RealPhotos, LocateWithoutIntrinsicsReportsIdsAndPixelCorners) {
  const std::string image = (kPhotos / "ocv_singlemarkersoriginal.jpg").string();
  const auto err = std::filesystem::temp_directory_path() / "ips_real_photos_locate.err";
  const std::string cmd = std::string(IPS_BINARY_DIR) + "/ips locate --image " + image +
                          " --dictionary DICT_6X6_250 --json 2>" + err.string();
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
  ASSERT_EQ(pclose(p), 0) << out;
  std::ifstream e(err);
  std::string stderr_text, line;
  while (std::getline(e, line)) stderr_text += line + "\n";
  EXPECT_NE(stderr_text.find("no --intrinsics"), std::string::npos) << stderr_text;
  const auto j = nlohmann::json::parse(out);
  EXPECT_EQ(j.at("intrinsics"), "guessed");

  ips::DetectorOptions o;
  o.dictionary = "DICT_6X6_250";
  const auto found = ips::Detector(o).detect(cv::imread(image, cv::IMREAD_GRAYSCALE));
  ASSERT_EQ(j.at("markers").size(), found.size());
  EXPECT_EQ(found.size(), 6u);  // OpenCV's default detector finds 6 (the test above)
  for (std::size_t i = 0; i < found.size(); ++i) {
    const auto& m = j.at("markers")[i];
    EXPECT_EQ(m.at("id").get<int>(), found[i].id);
    for (std::size_t k = 0; k < 4; ++k) {
      // ips decodes the JPEG with libjpeg-turbo, cv::imread with its own build: a few grey
      // levels apart in places.
      EXPECT_NEAR(m.at("corners")[k][0].get<double>(), found[i].corners_px[k].x, 0.1);
      EXPECT_NEAR(m.at("corners")[k][1].get<double>(), found[i].corners_px[k].y, 0.1);
    }
    EXPECT_GT(m.at("zc").get<double>(), 0.0);  // in front of the guessed camera
  }
}

}  // namespace
