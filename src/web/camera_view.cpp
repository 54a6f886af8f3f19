// The camera view image, made on the web server's thread from a snapshot the camera thread
// handed over: downscale, draw the daemon's detections, encode. OpenCV's rejected candidates
// go into the JSON only and the page draws them when asked (drawn into every image, the
// squares around correctly detected markers alarmed new users). The daemon's detector keeps
// no rejects, so the candidates are searched here, once per served image, on the downscaled
// frame (a few ms, off the camera threads).
#include <cmath>

#include <nlohmann/json.hpp>
#include <opencv2/aruco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/detect/detector.h"
#include "ips/web/web.h"

namespace ips {

namespace {
const cv::Scalar kDetected(0, 255, 0);  // BGR green: the page's legend says so

std::string encode(const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 80});
  return std::string(bytes.begin(), bytes.end());
}
}  // namespace

CameraView render_camera_view(const std::string& camera, const FrameSnapshot& snapshot, int width,
                              const std::string& dictionary) {
  CameraView view;
  const cv::Mat& gray = snapshot.gray;
  const double scale = gray.cols > width ? static_cast<double>(width) / gray.cols : 1.0;
  cv::Mat small;
  if (scale < 1.0)
    cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
  else
    small = gray;
  view.plain_jpeg = encode(small);

  std::vector<std::vector<cv::Point2f>> accepted, rejected;
  std::vector<int> ids;
  auto params = cv::aruco::DetectorParameters::create();
  cv::aruco::detectMarkers(small, cv::aruco::getPredefinedDictionary(dictionary_id(dictionary)), accepted, ids, params,
                           rejected);

  cv::Mat color;
  cv::cvtColor(small, color, cv::COLOR_GRAY2BGR);
  nlohmann::json info;
  info["camera"] = camera;
  info["sequence"] = snapshot.sequence;
  info["t_mono_ns"] = snapshot.t_mono_ns;
  info["width"] = small.cols;
  info["height"] = small.rows;
  info["scale"] = scale;
  info["detections"] = nlohmann::json::array();
  info["rejected"] = nlohmann::json::array();
  for (const auto& r : rejected) {
    nlohmann::json corners = nlohmann::json::array();
    for (const auto& p : r) corners.push_back({p.x, p.y});
    info["rejected"].push_back(corners);
  }
  const int thickness = 2;  // visible on a downscaled frame, survives JPEG's colour subsampling
  for (const auto& d : snapshot.detections) {
    std::vector<cv::Point> poly;
    nlohmann::json corners = nlohmann::json::array();
    double cx = 0, cy = 0;
    for (const auto& c : d.corners_px) {
      const double x = c.x * scale, y = c.y * scale;
      // Sub-pixel drawing (shift 4) so the outline lies on the detected corners.
      poly.emplace_back(cvRound(x * 16), cvRound(y * 16));
      corners.push_back({x, y});
      cx += x / 4;
      cy += y / 4;
    }
    cv::polylines(color, poly, true, kDetected, thickness, cv::LINE_AA, 4);
    cv::circle(color, poly[0], 3 * 16, kDetected, cv::FILLED, cv::LINE_AA, 4);  // corner 0: the marker's top-left
    cv::putText(color, std::to_string(d.id), cv::Point(cvRound(cx) + 6, cvRound(cy) - 6), cv::FONT_HERSHEY_SIMPLEX, 0.6,
                kDetected, 2, cv::LINE_AA);
    info["detections"].push_back({{"id", d.id}, {"corners", corners}});
  }
  view.jpeg = encode(color);
  view.info = info.dump();
  return view;
}

}  // namespace ips
