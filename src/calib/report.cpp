// What `ips calibrate` shows a person: the numbers as JSON and the report picture.
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/calib/calibrate.h"

namespace ips::calib {

std::string result_json(const CalibrationResult& r, const BoardSpec& board) {
  nlohmann::json views = nlohmann::json::array();
  for (const auto& v : r.views) {
    nlohmann::json j{{"image", v.name}, {"corners", v.corners}, {"used", v.used}};
    if (!v.residual.empty()) j["rms_px"] = v.rms;
    if (!v.why.empty()) j["why"] = v.why;
    if (v.corners_dropped > 0) j["outlier_corners"] = v.corners_dropped;
    views.push_back(j);
  }
  nlohmann::json out{{"model", r.model.kind() == CameraModel::Kind::kFisheye ? "fisheye" : "pinhole"},
                     {"board", board.str()},
                     {"image_width", r.model.size().width},
                     {"image_height", r.model.size().height},
                     {"K",
                      {r.model.K()(0, 0), r.model.K()(0, 1), r.model.K()(0, 2), r.model.K()(1, 0), r.model.K()(1, 1),
                       r.model.K()(1, 2), 0.0, 0.0, 1.0}},
                     {"D", r.model.D()},
                     {"rms_px", r.rms},
                     {"views_used", r.used_views},
                     {"images", r.views.size()},
                     {"coverage", r.coverage},
                     {"coverage_grid", {r.grid.width, r.grid.height}},
                     {"max_field_deg", r.max_field_deg},
                     {"corners_without_ray", r.corners_without_ray},
                     {"views", views}};
  out["polynomial_turns_back_deg"] = r.turn_back_deg ? nlohmann::json(*r.turn_back_deg) : nlohmann::json(nullptr);
  return out.dump(2) + "\n";
}

cv::Mat draw_report(const CalibrationResult& r, const BoardSpec& board, double magnify) {
  const cv::Size size = r.model.size();
  // At most 1600 px wide so that residual vectors stay readable on a screen.
  const double scale = std::min(1.0, 1600.0 / size.width);
  const int W = static_cast<int>(std::lround(size.width * scale));
  const int H = static_cast<int>(std::lround(size.height * scale));
  const int footer = 90;
  cv::Mat img(H + footer, W, CV_8UC3, cv::Scalar(40, 40, 40));
  // Coverage grid: cells with corners in green, empty cells dark.
  for (int gy = 0; gy < r.grid.height; ++gy) {
    for (int gx = 0; gx < r.grid.width; ++gx) {
      const int c = r.grid_counts[static_cast<std::size_t>(gy * r.grid.width + gx)];
      const cv::Point a(gx * W / r.grid.width, gy * H / r.grid.height);
      const cv::Point b((gx + 1) * W / r.grid.width - 1, (gy + 1) * H / r.grid.height - 1);
      cv::rectangle(img, a, b, c > 0 ? cv::Scalar(60, 95, 60) : cv::Scalar(30, 30, 55), cv::FILLED);
      cv::rectangle(img, a, b, cv::Scalar(80, 80, 80), 1);
    }
  }
  // Where a fitted fisheye polynomial turns back: no ray beyond this circle.
  if (r.turn_back_deg) {
    cv::Mat area = img(cv::Rect(0, 0, W, H));  // not over the text below
    cv::circle(area, cv::Point2d(r.model.K()(0, 2) * scale, r.model.K()(1, 2) * scale),
               static_cast<int>(r.turn_back_radius_px * scale), cv::Scalar(0, 165, 255), 2, cv::LINE_AA);
  }
  for (const auto& v : r.views) {
    const cv::Scalar dot = v.used ? cv::Scalar(255, 255, 255) : cv::Scalar(60, 60, 255);
    const cv::Scalar vec = v.used ? cv::Scalar(0, 230, 255) : cv::Scalar(60, 60, 255);
    for (std::size_t k = 0; k < v.residual.size(); ++k) {
      const cv::Point2d p = v.px[k] * scale;
      cv::circle(img, p, 1, dot, cv::FILLED, cv::LINE_AA);
      cv::line(img, p, p + v.residual[k] * (magnify * scale), vec, 1, cv::LINE_AA);
    }
  }
  char line[256];
  const auto text = [&](int row, const std::string& s, cv::Scalar colour) {
    cv::putText(img, s, cv::Point(10, H + 24 + 26 * row), cv::FONT_HERSHEY_SIMPLEX, 0.6, colour, 1, cv::LINE_AA);
  };
  int dropped = 0;
  for (const auto& v : r.views) dropped += (!v.used && !v.residual.empty()) ? 1 : 0;
  std::snprintf(line, sizeof line, "%s  RMS %.3f px over %d views (%d not used, red)   residuals x%.0f (yellow)",
                r.model.kind() == CameraModel::Kind::kFisheye ? "fisheye" : "pinhole", r.rms, r.used_views, dropped,
                magnify);
  text(0, line, cv::Scalar(255, 255, 255));
  std::snprintf(line, sizeof line,
                "coverage %.0f%% of the %dx%d grid (green = has corners)   largest field angle %.1f deg",
                100 * r.coverage, r.grid.width, r.grid.height, r.max_field_deg);
  text(1, line, cv::Scalar(255, 255, 255));
  if (r.turn_back_deg) {
    std::snprintf(line, sizeof line, "%s   polynomial turns back at %.1f deg (orange circle): no ray beyond",
                  board.str().c_str(), *r.turn_back_deg);
  } else {
    std::snprintf(line, sizeof line, "%s", board.str().c_str());
  }
  text(2, line, cv::Scalar(200, 200, 200));
  return img;
}

}  // namespace ips::calib
