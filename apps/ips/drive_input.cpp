#include "drive_input.h"

#include <fstream>
#include <map>

#include "image_io.h"
#include "ips/core/csv_fields.h"
#include "ips/core/error.h"
#include "ips/survey/survey.h"

namespace fs = std::filesystem;

namespace ips::cli {

std::vector<FrameInput> read_times_csv(const fs::path& dir) {
  const fs::path path = dir / "times.csv";
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open (expected a header file,t_ns and a row per frame)");
  std::string line;
  std::getline(in, line);
  const auto header = split_csv_line(line);
  if (header.size() != 2 || header[0] != "file" || header[1] != "t_ns") {
    throw InputError(path.string() + ":1: expected the header file,t_ns");
  }
  std::vector<FrameInput> out;
  for (int n = 2; std::getline(in, line); ++n) {
    if (trim_csv_field(line).empty()) continue;
    const auto f = split_csv_line(line);
    const std::string at = path.string() + ":" + std::to_string(n);
    if (f.size() != 2 || f[0].empty()) throw InputError(at + ": expected file,t_ns");
    FrameInput frame;
    frame.file = (dir / std::string(f[0])).string();
    try {
      std::size_t used = 0;
      const std::string t(f[1]);
      frame.t_ns = std::stoll(t, &used);
      if (used != t.size()) throw std::invalid_argument("t_ns");
    } catch (const std::exception&) {
      throw InputError(at + ": t_ns: expected a whole number of nanoseconds, got '" + std::string(f[1]) + "'");
    }
    if (!out.empty() && frame.t_ns <= out.back().t_ns) {
      throw InputError(at + ": t_ns: not after the previous frame's (frames must be in capture order)");
    }
    out.push_back(std::move(frame));
  }
  if (out.empty()) throw InputError(path.string() + ": no frames");
  return out;
}

std::vector<FrameInput> read_session_frames(const fs::path& dir, const std::string& camera, const CameraModel& lens,
                                            std::string* dictionary) {
  const survey::Session session = survey::load_session(dir);
  if (dictionary != nullptr) *dictionary = session.dictionary;
  std::string names;
  const survey::SessionCamera* cam = nullptr;
  for (const auto& c : session.cameras) {
    names += (names.empty() ? "" : ", ") + c.name;
    if (c.name == camera || (camera.empty() && session.cameras.size() == 1)) cam = &c;
  }
  if (cam == nullptr) {
    throw InputError(dir.string() + ": " +
                     (camera.empty() ? "several cameras (" + names + "): say which with --camera"
                                     : "no camera '" + camera + "' (cameras: " + names + ")"));
  }
  if (session.cameras.size() == 1) {
    const std::string expected = survey::camera_fingerprint({{cam->name, lens}});
    if (session.fingerprint != expected) {
      throw InputError((dir / "session.txt").string() + ": fingerprint " + session.fingerprint + " is not camera '" +
                       cam->name + "' with the intrinsics of the robot's configuration (" + expected +
                       "): recorded with another calibration?");
    }
  }
  std::map<std::int64_t, FrameInput> frames;
  for (const auto& d : cam->detections) {
    FrameInput& f = frames[d.t_ns];
    f.t_ns = d.t_ns;
    f.markers.push_back({d.id, d.corners});
  }
  std::vector<FrameInput> out;
  for (auto& [t, f] : frames) out.push_back(std::move(f));
  if (out.empty()) throw InputError(dir.string() + ": camera '" + cam->name + "' recorded no detection");
  return out;
}

std::vector<MarkerDetection> detections_of(const FrameInput& frame, Detector& detector, const CameraModel& camera,
                                           const std::string& intrinsics_name) {
  if (frame.file.empty()) return frame.markers;
  const cv::Mat gray = read_gray_image(frame.file);
  if (gray.size() != camera.size()) {
    throw InputError(frame.file + ": " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                     " but the intrinsics " + intrinsics_name + " are for " + std::to_string(camera.size().width) +
                     "x" + std::to_string(camera.size().height));
  }
  return detector.detect(gray, &camera);
}

}  // namespace ips::cli
