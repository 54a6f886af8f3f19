// The survey's report image: a top view of the lab (x right, y up) with each camera's centre
// and viewing direction, its footprint on the floor (the image border's rays meeting z = 0),
// the wand positions used and the references (known position, and where each camera's
// surveyed pose puts it when solved without it, the error magnified).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/core/error.h"
#include "ips/survey/survey.h"

namespace ips::survey {
namespace {

const cv::Scalar kColours[] = {{40, 40, 220}, {40, 160, 40},  {200, 80, 40},
                               {0, 150, 220}, {160, 40, 160}, {120, 120, 0}};

std::vector<Eigen::Vector2d> footprint(const CameraResult& cam, const CameraModel& model) {
  std::vector<Eigen::Vector2d> out;
  const int w = model.size().width, h = model.size().height;
  const int steps = 24;
  for (int i = 0; i < 4 * steps; ++i) {
    const int side = i / steps;
    const double s = static_cast<double>(i % steps) / steps;
    Point2 px;
    if (side == 0) px = {s * (w - 1), 0};
    if (side == 1) px = {w - 1.0, s * (h - 1)};
    if (side == 2) px = {(1 - s) * (w - 1), h - 1.0};
    if (side == 3) px = {0, (1 - s) * (h - 1)};
    const Point2 n = model.undistort(px);
    if (!std::isfinite(n.x) || !std::isfinite(n.y)) continue;
    const Eigen::Vector3d d = cam.R_wc * Eigen::Vector3d(n.x, n.y, 1.0);
    if (!(d.z() < -1e-3)) continue;
    const double t = -cam.centre.z() / d.z();
    if (t > 50) continue;
    out.push_back((cam.centre + t * d).head<2>());
  }
  return out;
}

}  // namespace

void write_report_png(const SurveyResult& result, const SurveyInput& input, const std::filesystem::path& path) {
  std::vector<std::vector<Eigen::Vector2d>> feet;
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  auto grow = [&](const Eigen::Vector2d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (std::size_t c = 0; c < result.cameras.size(); ++c) {
    feet.push_back(footprint(result.cameras[c], input.cameras[c].intrinsics));
    for (const auto& p : feet.back()) grow(p);
    grow(result.cameras[c].centre.head<2>());
  }
  for (const auto& r : result.references) grow(r.known.head<2>());
  for (const auto& p : result.wand) grow(p.head<2>());
  lo -= Eigen::Vector2d(0.3, 0.3);
  hi += Eigen::Vector2d(0.3, 0.3);
  const double scale = 900.0 / std::max(hi.x() - lo.x(), hi.y() - lo.y());  // px per metre
  const int W = static_cast<int>((hi.x() - lo.x()) * scale) + 1, H = static_cast<int>((hi.y() - lo.y()) * scale) + 61;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  auto px = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() - lo.x()) * scale)),
                     static_cast<int>(std::lround((hi.y() - p.y()) * scale)) + 60);
  };
  // A 1 m grid.
  for (double x = std::ceil(lo.x()); x <= hi.x(); x += 1.0)
    cv::line(img, px({x, lo.y()}), px({x, hi.y()}), cv::Scalar(225, 225, 225), 1);
  for (double y = std::ceil(lo.y()); y <= hi.y(); y += 1.0)
    cv::line(img, px({lo.x(), y}), px({hi.x(), y}), cv::Scalar(225, 225, 225), 1);
  for (std::size_t c = 0; c < result.cameras.size(); ++c) {
    const cv::Scalar colour = kColours[c % std::size(kColours)];
    std::vector<cv::Point> poly;
    for (const auto& p : feet[c]) poly.push_back(px(p));
    if (poly.size() > 2) cv::polylines(img, poly, true, colour, 2, cv::LINE_AA);
    const CameraResult& cam = result.cameras[c];
    cv::circle(img, px(cam.centre.head<2>()), 7, colour, cv::FILLED, cv::LINE_AA);
    const Eigen::Vector3d x_axis = cam.R_wc.col(0);  // image right
    cv::arrowedLine(img, px(cam.centre.head<2>()), px(cam.centre.head<2>() + 0.4 * x_axis.head<2>().normalized()),
                    colour, 2, cv::LINE_AA);
    char text[160];
    std::snprintf(text, sizeof text, "%s (%.2f, %.2f, %.2f) %.2f px", cam.name.c_str(), cam.centre.x(), cam.centre.y(),
                  cam.centre.z(), cam.rms_px);
    cv::putText(img, text, px(cam.centre.head<2>()) + cv::Point(10, -10), cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1,
                cv::LINE_AA);
  }
  for (std::size_t i = 1; i < result.wand.size(); ++i)
    cv::line(img, px(result.wand[i - 1].head<2>()), px(result.wand[i].head<2>()), cv::Scalar(180, 180, 180), 1,
             cv::LINE_AA);
  for (const auto& p : result.wand) cv::circle(img, px(p.head<2>()), 3, cv::Scalar(90, 90, 90), cv::FILLED);
  for (const auto& r : result.references) {
    const cv::Point at = px(r.known.head<2>());
    cv::rectangle(img, at - cv::Point(6, 6), at + cv::Point(6, 6), cv::Scalar(0, 0, 0), 2);
    double worst = 0;
    // The leave-one-out error (the fit's own residual at a reference is ~0 by construction).
    for (const auto& [name, e] : r.left_out.empty() ? r.residual : r.left_out) {
      worst = std::max(worst, e.norm());
      // The error magnified 100x (1 cm is drawn as 1 m).
      cv::line(img, at, px(r.known.head<2>() + 100.0 * e), cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
    }
    char text[80];
    std::snprintf(text, sizeof text, "ref %d: left out <= %.1f mm", r.id, worst * 1000);
    cv::putText(img, text, at + cv::Point(9, 16), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  char title[200];
  std::snprintf(title, sizeof title,
                "ips survey: %zu cameras, %d instants, RMS %.3f px; grid 1 m; reference errors x100",
                result.cameras.size(), result.instants, result.final_rms_px);
  cv::putText(img, title, cv::Point(10, 30), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  if (!cv::imwrite(path.string(), img)) throw InputError(path.string() + ": cannot write the report image");
}

}  // namespace ips::survey
