// `ips map`: the ceiling's marker map from a drive of the robot's up-facing camera (a folder of
// frames with times.csv, or an `ips record` session), put in the lab's frame by references
// (docs/inside-out.md). Writes map.json and, on request, a report PNG (the map from below, the
// drive, the references); bad input exits 2 and writes nothing.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command.h"
#include "drive_input.h"
#include "image_io.h"
#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/insideout/map_builder.h"
#include "ips/insideout/robot_config.h"
#include "ips/survey/survey.h"

namespace cmd_map {  // named, not anonymous: unique in a unity build

struct Args {
  std::string images, session, camera, config, refs, out, report;
  std::string dictionary = "DICT_4X4_100";
  double marker_length = 0.2;
};

// The map from below (x right, y up, as a floor plan), the drive, the references circled.
void write_report(const ips::MapBuildResult& r, const std::vector<ips::MapReference>& refs, const std::string& path) {
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  auto grow = [&](double x, double y) {
    x0 = std::min(x0, x);
    y0 = std::min(y0, y);
    x1 = std::max(x1, x);
    y1 = std::max(y1, y);
  };
  for (const auto& m : r.map.markers) grow(m.centre.x(), m.centre.y());
  for (const auto& c : r.cameras) grow(c.position.x(), c.position.y());
  const double pad = 0.5, span = std::max(x1 - x0, y1 - y0) + 2 * pad;
  const int size = 900;
  const double s = (size - 80) / span;
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(255, 255, 255));
  auto px = [&](double x, double y) {
    return cv::Point(40 + static_cast<int>((x - x0 + pad) * s), size - 40 - static_cast<int>((y - y0 + pad) * s));
  };
  for (double g = std::ceil(x0 - pad); g <= x1 + pad; g += 1.0) {
    cv::line(img, px(g, y0 - pad), px(g, y1 + pad), cv::Scalar(230, 230, 230));
    cv::putText(img, std::to_string(static_cast<int>(g)) + " m", px(g, y0 - pad) + cv::Point(2, 14),
                cv::FONT_HERSHEY_SIMPLEX, 0.35, {120, 120, 120});
  }
  for (double g = std::ceil(y0 - pad); g <= y1 + pad; g += 1.0) {
    cv::line(img, px(x0 - pad, g), px(x1 + pad, g), cv::Scalar(230, 230, 230));
  }
  std::vector<cv::Point> path_px;
  for (const auto& c : r.cameras) path_px.push_back(px(c.position.x(), c.position.y()));
  if (path_px.size() > 1) cv::polylines(img, path_px, false, cv::Scalar(200, 120, 0), 1, cv::LINE_AA);
  for (const auto& m : r.map.markers) {
    const auto corners = m.corners();
    std::vector<cv::Point> q;
    for (const auto& c : corners) q.push_back(px(c.x(), c.y()));
    cv::polylines(img, q, true, cv::Scalar(0, 0, 0), 2, cv::LINE_AA);
    cv::line(img, q[0], q[1], cv::Scalar(0, 0, 220), 2, cv::LINE_AA);  // the printed top edge
    cv::putText(img, std::to_string(m.id), px(m.centre.x(), m.centre.y()) + cv::Point(-8, 5), cv::FONT_HERSHEY_SIMPLEX,
                0.45, {0, 0, 0}, 1, cv::LINE_AA);
  }
  for (const auto& ref : refs) {
    cv::circle(img, px(ref.position.x(), ref.position.y()), 18, cv::Scalar(0, 160, 0), 2, cv::LINE_AA);
  }
  // Each marker's 1-sigma ellipse (x, y; axis-aligned), magnified so that the largest is 30 px.
  double largest = 0;
  for (const auto& m : r.map.markers)
    if (m.sigma) largest = std::max({largest, (*m.sigma)[0], (*m.sigma)[1]});
  const double magnify = largest > 0 ? 30.0 / (largest * s) : 0.0;
  for (const auto& m : r.map.markers) {
    if (!m.sigma || magnify == 0) continue;
    const cv::Size axes(std::max(1, static_cast<int>(std::lround((*m.sigma)[0] * s * magnify))),
                        std::max(1, static_cast<int>(std::lround((*m.sigma)[1] * s * magnify))));
    cv::ellipse(img, px(m.centre.x(), m.centre.y()), axes, 0, 0, 360, cv::Scalar(160, 0, 160), 1, cv::LINE_AA);
  }
  char title[200];
  std::snprintf(title, sizeof title, "%zu markers from %d of %d frames, %d corners, RMS %.2f px; green: references",
                r.map.markers.size(), r.frames_used, r.frames, r.corners, r.rms_px);
  cv::putText(img, title, {10, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(img,
              "a floor plan (seen from above, x right, y up); red: each marker's printed top edge; blue: the drive",
              {10, 40}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {80, 80, 80}, 1, cv::LINE_AA);
  if (magnify > 0) {
    char sigmas[200];
    std::snprintf(sigmas, sizeof sigmas,
                  "purple: 1-sigma ellipses relative to marker %d, magnified %.0fx (largest %.2f mm)", r.anchor,
                  magnify, largest * 1000);
    cv::putText(img, sigmas, {10, 58}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {160, 0, 160}, 1, cv::LINE_AA);
  }
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", img, png)) throw std::runtime_error("cannot encode the report");
  ips::cli::write_file_atomically(path, std::string(png.begin(), png.end()));
}

int run(const Args& a) {
  if (!(a.marker_length > 0.005 && a.marker_length < 5)) throw ips::InputError("--marker-length must be 0.005..5 m");
  ips::RobotCameraConfig config = ips::load_robot_config(a.config);
  const ips::CameraModel camera = ips::CameraModel::load(config.intrinsics);
  std::vector<ips::MapReference> refs;
  for (const auto& r : ips::survey::load_references(a.refs, 1)) refs.push_back({r.id, r.position, r.yaw});
  std::string dictionary = a.dictionary;
  const bool from_images = !a.images.empty();
  const auto inputs = from_images ? ips::cli::read_times_csv(a.images)
                                  : ips::cli::read_session_frames(a.session, a.camera, camera, &dictionary);
  config.detection.dictionary = dictionary;
  ips::Detector detector(config.detection);
  std::vector<ips::DriveFrame> frames;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    frames.push_back(
        {inputs[k].t_ns, ips::cli::detections_of(inputs[k], detector, camera, config.intrinsics.string())});
    if (from_images && ((k + 1) % 50 == 0 || k + 1 == inputs.size())) {
      std::fprintf(stderr, "\rdetecting: frame %zu/%zu", k + 1, inputs.size());
    }
  }
  if (from_images) std::fprintf(stderr, "\n");
  ips::MapBuildOptions options;
  options.dictionary = dictionary;
  options.sizes.default_length = a.marker_length;
  ips::MapBuildResult r;
  try {
    r = ips::build_ceiling_map(frames, camera, refs, options);
  } catch (const ips::InputError& e) {
    throw ips::InputError(a.refs + ": " + e.what());
  }
  ips::cli::write_file_atomically(a.out, r.map.to_json());
  std::printf("%zu markers from %d of %d frames (%d corners, RMS %.2f px); wrote %s\n", r.map.markers.size(),
              r.frames_used, r.frames, r.corners, r.rms_px, a.out.c_str());
  double worst = 0;
  int worst_id = -1;
  for (const auto& m : r.map.markers)
    if (m.sigma && std::hypot((*m.sigma)[0], (*m.sigma)[1]) > worst) {
      worst = std::hypot((*m.sigma)[0], (*m.sigma)[1]);
      worst_id = m.id;
    }
  if (worst_id >= 0)
    std::printf("  uncertainty relative to marker %d (held): largest 1-sigma %.2f mm (2-D), marker %d\n", r.anchor,
                worst * 1000, worst_id);
  for (const auto& ref : r.references) {
    std::printf("  reference %d: mapped %+.1f %+.1f %+.1f mm from its given centre", ref.id, ref.offset.x() * 1000,
                ref.offset.y() * 1000, ref.offset.z() * 1000);
    if (ref.yaw_offset != 0.0) std::printf(", yaw %+.3f deg", ref.yaw_offset * 180 / M_PI);
    std::printf("\n");
  }
  if (!r.unconnected.empty()) {
    std::string ids;
    for (int id : r.unconnected) ids += " " + std::to_string(id);
    std::printf("  seen only in frames that share no marker with the map (not mapped):%s\n", ids.c_str());
  }
  if (!a.report.empty()) {
    write_report(r, refs, a.report);
    std::printf("wrote %s\n", a.report.c_str());
  }
  return 0;
}

IPS_REGISTER_COMMAND(
    "map", "The ceiling's marker map from a drive of a robot's up-facing camera (inside-out)",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      auto* images = sub.add_option("--images", a->images, "A folder of frames with times.csv (file,t_ns)");
      auto* session = sub.add_option("--session", a->session, "An ips record session of the robot's camera");
      images->excludes(session);
      sub.add_option("--camera", a->camera, "The session's camera (when it has several)")->needs(session);
      sub.add_option("--config", a->config, "The robot's camera: robot.yaml (intrinsics, mount, detection)")
          ->required()
          ->check(CLI::ExistingFile);
      sub.add_option("--refs", a->refs,
                     "refs.yaml: markers at known places, >= 2 centres or 1 with yaw_deg (as for ips survey)")
          ->required();
      sub.add_option("--marker-length", a->marker_length, "The markers' black-square edge, m (the map's scale)")
          ->required();
      sub.add_option("--dictionary", a->dictionary, "ArUco dictionary (--images; a session has its own)")
          ->capture_default_str();
      sub.add_option("--out", a->out, "map.json to write")->required();
      sub.add_option("--report", a->report, "A PNG of the map from below with the drive");
      return [a] {
        if (a->images.empty() && a->session.empty()) throw ips::InputError("give --images DIR or --session DIR");
        return run(*a);
      };
    });

}  // namespace cmd_map
