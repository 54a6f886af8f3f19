#include "ips/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <tuple>

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "plane_sampling.h"
#include "sim/lamps.h"

#include "ips/core/error.h"
#include "ips/detect/detector.h"
#include "ips/geometry/marker_geometry.h"

namespace ips::sim {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
constexpr double kWallGrey = 55.0;      // what is seen beyond the floor's edge
constexpr double kCeilingGrey = 170.0;  // a camera looking up sees a plain, light ceiling
enum Region { kOffPlate = 0, kMargin = 1, kBlack = 2, kWhite = 3 };

// Corners of the black square in marker units (x right, y up as printed), ArUco order.
constexpr double kCorners[4][2] = {{-0.5, 0.5}, {0.5, 0.5}, {0.5, -0.5}, {-0.5, -0.5}};

// The point (a, b) marker units from the centre along the marker's x, y axes (any orientation).
Eigen::Vector3d marker_point(const MarkerPose& p, double length, double a, double b) {
  const Eigen::Matrix3d f = p.frame();
  return Eigen::Vector3d(p.x, p.y, p.z) + length * (a * f.col(0) + b * f.col(1));
}

// True when the camera sees the printed side of the marker (a body's face turned away is
// hidden behind the body).
bool faces_camera(const MarkerPose& p, const SceneCamera& cam) {
  return p.frame().col(2).dot(cam.position - Eigen::Vector3d(p.x, p.y, p.z)) > 0;
}

// Smooth value noise on the floor: a coarse random grid, bilinearly interpolated.
class FloorTexture {
 public:
  FloorTexture(const Floor& f) : f_(f) {
    std::mt19937 rng(f.seed);
    std::normal_distribution<float> n(0.0f, 1.0f);
    for (int o = 0; o < 2; ++o) {
      const double cell = f.texture_scale / (o == 0 ? 1.0 : 4.0);
      const int nx = static_cast<int>(std::ceil(f.size_x / cell)) + 2;
      const int ny = static_cast<int>(std::ceil(f.size_y / cell)) + 2;
      grids_[o].create(ny, nx, CV_32F);
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) grids_[o].at<float>(y, x) = n(rng);
      cells_[o] = cell;
    }
  }
  double grey(double x, double y) const {
    if (x < 0 || y < 0 || x > f_.size_x || y > f_.size_y) return kWallGrey;
    double v = 0.0;
    for (int o = 0; o < 2; ++o) {
      const double gx = x / cells_[o], gy = y / cells_[o];
      const int x0 = static_cast<int>(gx), y0 = static_cast<int>(gy);
      const double fx = gx - x0, fy = gy - y0;
      const cv::Mat& g = grids_[o];
      const double val = (1 - fy) * ((1 - fx) * g.at<float>(y0, x0) + fx * g.at<float>(y0, x0 + 1)) +
                         fy * ((1 - fx) * g.at<float>(y0 + 1, x0) + fx * g.at<float>(y0 + 1, x0 + 1));
      v += (o == 0 ? 0.8 : 0.4) * val;
    }
    return f_.grey + f_.texture_contrast * v;
  }

 private:
  Floor f_;
  cv::Mat grids_[2];
  double cells_[2] = {1, 1};
};

// The ray map and the noise pool depend only on the camera (resp. the noise settings) and
// take ~1 s to build at 1080p, so they are built once per process and shared by every
// renderer of the same camera (several sources of one scene, repeated tests).
std::shared_ptr<const cv::Mat> ray_map(const CameraModel& model) {
  char key[512];
  std::snprintf(key, sizeof key, "%d %dx%d K %.17g %.17g %.17g %.17g %.17g D", static_cast<int>(model.kind()),
                model.size().width, model.size().height, model.K()(0, 0), model.K()(0, 1), model.K()(0, 2),
                model.K()(1, 1), model.K()(1, 2));
  std::string k = key;
  for (double d : model.D()) {
    std::snprintf(key, sizeof key, " %.17g", d);
    k += key;
  }
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const cv::Mat>> cache;
  const std::lock_guard lock(mutex);
  if (auto it = cache.find(k); it != cache.end()) return it->second;
  auto uv = std::make_shared<cv::Mat>(model.size(), CV_32FC2);
  cv::parallel_for_(cv::Range(0, model.size().height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      auto* row = uv->ptr<cv::Vec2f>(y);
      for (int x = 0; x < model.size().width; ++x) {
        const Point2 n = model.undistort({static_cast<double>(x), static_cast<double>(y)});
        row[x] =
            std::isnan(n.x) ? cv::Vec2f(kNaNf, kNaNf) : cv::Vec2f(static_cast<float>(n.x), static_cast<float>(n.y));
      }
    }
  });
  cache.emplace(k, uv);
  return uv;
}

std::shared_ptr<const std::vector<std::int8_t>> noise_pool(double sigma, unsigned seed, std::size_t size) {
  static std::mutex mutex;
  static std::map<std::tuple<double, unsigned, std::size_t>, std::shared_ptr<const std::vector<std::int8_t>>> cache;
  const std::lock_guard lock(mutex);
  const auto key = std::make_tuple(sigma, seed, size);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, static_cast<float>(sigma));
  auto pool = std::make_shared<std::vector<std::int8_t>>(size);
  for (auto& v : *pool) v = static_cast<std::int8_t>(std::clamp(std::lround(normal(rng)), -127L, 127L));
  cache.emplace(key, pool);
  return pool;
}

}  // namespace

cv::Mat marker_pattern(const std::string& dictionary, int id) {
  auto dict = cv::aruco::getPredefinedDictionary(dictionary_id(dictionary));
  if (id < 0 || id >= dict->bytesList.rows) {
    throw InputError("marker id " + std::to_string(id) + " is not in " + dictionary + " (0.." +
                     std::to_string(dict->bytesList.rows - 1) + ")");
  }
  cv::Mat img;
  cv::aruco::drawMarker(dict, id, dict->markerSize + 2, img, 1);
  cv::Mat cells;
  cv::threshold(img, cells, 127, 1, cv::THRESH_BINARY);
  return cells;
}

CameraRenderer::CameraRenderer(const Scene& scene, std::size_t camera_index)
    : scene_(scene), camera_index_(camera_index) {
  const SceneCamera& cam = camera();
  width_ = cam.model.size().width;
  height_ = cam.model.size().height;
  uv_ = ray_map(cam.model);
  gain_.create(height_, width_, CV_32F);
  background_.create(height_, width_, CV_8U);
  const FloorTexture texture(scene.floor);
  const auto& rs = scene.render;
  const double cx = cam.model.K()(0, 2), cy = cam.model.K()(1, 2);
  const double r_corner = std::hypot(std::max(cx, width_ - cx), std::max(cy, height_ - cy));
  cv::parallel_for_(cv::Range(0, height_), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const auto* uv = uv_->ptr<cv::Vec2f>(y);
      auto* gain = gain_.ptr<float>(y);
      auto* bg = background_.ptr<std::uint8_t>(y);
      for (int x = 0; x < width_; ++x) {
        const Point2 n{uv[x][0], uv[x][1]};
        const double r = std::hypot(x - cx, y - cy) / r_corner;
        double g = 1.0 - rs.vignetting * r * r;
        if (std::isnan(n.x)) {
          gain[x] = static_cast<float>(g);
          bg[x] = 0;  // beyond the lens' image circle
          continue;
        }
        const Eigen::Vector3d d = cam.R_wc * Eigen::Vector3d(n.x, n.y, 1.0);
        double grey = cam.looks_up ? kCeilingGrey : kWallGrey;
        // A camera looking up sees the ceiling wherever it is: its background cannot depend
        // on where a riding camera is (what lies below its horizon is drawn as ceiling too).
        if (d.z() < -1e-9 && !cam.looks_up) {
          const double t = -cam.position.z() / d.z();
          const double wx = cam.position.x() + t * d.x();
          const double wy = cam.position.y() + t * d.y();
          grey = texture.grey(wx, wy);
          g *= 1.0 + rs.gradient * (std::clamp(wx / scene.floor.size_x, 0.0, 1.0) - 0.5);
        }
        gain[x] = static_cast<float>(g);
        bg[x] = cv::saturate_cast<std::uint8_t>(grey * g);
      }
    }
  });
  // Noise pool: larger than a frame so that each frame takes a different window of it.
  noise_ = noise_pool(rs.noise_sigma, rs.seed * 7919u + static_cast<unsigned>(camera_index),
                      static_cast<std::size_t>(width_) * height_ * 2);
}

MarkerTruth CameraRenderer::truth_of(const SceneMarker& marker, const MarkerPose& pose) const {
  return truth_in(camera(), marker, pose);
}

MarkerTruth CameraRenderer::truth_in(const SceneCamera& cam, const SceneMarker& marker, const MarkerPose& pose) const {
  MarkerTruth t;
  t.id = marker.id;
  t.pose = pose;
  t.centre_cam = cam.world_to_camera({pose.x, pose.y, pose.z});
  t.formula.id = marker.id;
  t.formula.edge_length = marker.length;
  if (!pose.present) return t;  // picked up: not visible anywhere
  bool visible = faces_camera(pose, cam);
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector3d pc = cam.world_to_camera(marker_point(pose, marker.length, kCorners[i][0], kCorners[i][1]));
    const Point2 n{pc.x() / pc.z(), pc.y() / pc.z()};
    t.formula.corners_norm[i] = n;
    const bool in_front = pc.z() > 0 && std::atan2(std::hypot(pc.x(), pc.y()), pc.z()) < cam.model.max_theta();
    const Point2 px = in_front ? cam.model.project(n) : Point2{-1e9, -1e9};
    t.formula.corners_px[i] = px;
    t.corners_px[i] = px;
    visible = visible && in_front && px.x >= 3 && px.y >= 3 && px.x <= width_ - 4 && px.y <= height_ - 4;
  }
  t.visible = visible;
  if (visible) t.formula = locate_from_normalised(t.formula);
  return t;
}

std::vector<MarkerTruth> CameraRenderer::truth(double time) const {
  std::vector<MarkerTruth> out;
  const SceneCamera cam = scene_.camera_at(camera_index_, time);
  for (std::size_t i = 0; i < scene_.markers.size(); ++i) {
    out.push_back(truth_in(cam, scene_.markers[i], scene_.marker_pose_at(i, time)));
  }
  return out;
}

void CameraRenderer::render(double t, cv::Mat& gray, std::uint64_t noise_index) const {
  const auto& rs = scene_.render;
  // The instants of the exposure; a riding camera moves across them too (motion blur).
  std::vector<double> times{t};
  if (rs.exposure > 0 && rs.blur_samples > 1) {
    times.clear();
    for (int k = 0; k < rs.blur_samples; ++k) {
      times.push_back(t + rs.exposure * (k / static_cast<double>(rs.blur_samples - 1) - 0.5));
    }
  }
  std::vector<SceneCamera> cams;
  for (double ti : times) cams.push_back(scene_.camera_at(camera_index_, ti));
  background_.copyTo(gray);
  draw_lamps(scene_.lamps, scene_.camera_at(camera_index_, t), *uv_, gain_, gray);
  for (std::size_t i = 0; i < scene_.markers.size(); ++i) {
    PlacedMarker p{scene_.markers[i], {}};
    std::vector<SceneCamera> seen_by;
    for (std::size_t k = 0; k < times.size(); ++k) {
      const MarkerPose pose = scene_.marker_pose_at(i, times[k]);
      // A marker picked up during the exposure is drawn only for the time it was there.
      if (!pose.present || !faces_camera(pose, cams[k])) continue;
      p.poses.push_back(pose);
      seen_by.push_back(cams[k]);
    }
    if (p.poses.empty()) continue;
    draw_marker(p, seen_by, gray);
  }
  add_noise(gray, noise_index);
}

void CameraRenderer::render_markers(const std::vector<PlacedMarker>& markers, cv::Mat& gray,
                                    std::uint64_t noise_index) const {
  background_.copyTo(gray);
  const std::vector<SceneCamera> cams{camera()};
  for (const auto& m : markers) draw_marker(m, cams, gray);
  add_noise(gray, noise_index);
}

void CameraRenderer::add_noise(cv::Mat& gray, std::uint64_t noise_index) const {
  if (gray.type() != CV_8UC1 || gray.rows != height_ || gray.cols != width_ || !gray.isContinuous()) {
    throw std::invalid_argument("CameraRenderer::add_noise: not a frame of this camera");
  }
  if (scene_.render.noise_sigma > 0) {
    const std::size_t n = static_cast<std::size_t>(width_) * height_;
    const std::size_t range = noise_->size() - n;
    // Odd multiplier: consecutive frames take far-apart windows of the pool.
    const std::size_t offset = static_cast<std::size_t>((noise_index * 2654435761ULL) % range);
    const std::int8_t* noise = noise_->data() + offset;
    std::uint8_t* px = gray.ptr<std::uint8_t>(0);
    for (std::size_t i = 0; i < n; ++i) {
      const int v = px[i] + noise[i];
      px[i] = static_cast<std::uint8_t>(v < 0 ? 0 : (v > 255 ? 255 : v));
    }
  }
}

void CameraRenderer::draw_marker(const PlacedMarker& pm, const std::vector<SceneCamera>& cams, cv::Mat& gray) const {
  const SceneMarker& mk = pm.marker;
  auto cam_of = [&](std::size_t k) -> const SceneCamera& { return cams.size() == 1 ? cams[0] : cams[k]; };
  const cv::Mat pattern = marker_pattern(scene_.dictionary, mk.id);
  const int cells = pattern.rows;
  const double half_plate = 0.5 + (mk.margin >= 0 ? mk.margin / mk.length : 1.0 / cells);

  // Bounding box: the plate's outline, densely sampled (fisheye edges curve), every pose.
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  constexpr int kPerEdge = 16;
  for (std::size_t j = 0; j < pm.poses.size(); ++j) {
    const MarkerPose& pose = pm.poses[j];
    const SceneCamera& cam = cam_of(j);
    for (int e = 0; e < 4; ++e) {
      for (int k = 0; k < kPerEdge; ++k) {
        const double s = -half_plate + 2 * half_plate * k / kPerEdge;
        const double a = e == 0 ? s : (e == 1 ? half_plate : (e == 2 ? -s : -half_plate));
        const double b = e == 0 ? half_plate : (e == 1 ? -s : (e == 2 ? -half_plate : s));
        const Eigen::Vector3d pc = cam.world_to_camera(marker_point(pose, mk.length, a, b));
        if (!(pc.z() > 1e-6) || std::atan2(std::hypot(pc.x(), pc.y()), pc.z()) >= cam.model.max_theta()) {
          continue;  // this part of the plate is outside the lens' field
        }
        const Point2 px = cam.model.project({pc.x() / pc.z(), pc.y() / pc.z()});
        x0 = std::min(x0, px.x);
        y0 = std::min(y0, px.y);
        x1 = std::max(x1, px.x);
        y1 = std::max(y1, px.y);
      }
    }
  }
  const int bx0 = std::max(0, static_cast<int>(std::floor(x0)) - 2);
  const int by0 = std::max(0, static_cast<int>(std::floor(y0)) - 2);
  const int bx1 = std::min(width_ - 1, static_cast<int>(std::ceil(x1)) + 2);
  const int by1 = std::min(height_ - 1, static_cast<int>(std::ceil(y1)) + 2);
  if (bx0 > bx1 || by0 > by1) return;
  const int bw = bx1 - bx0 + 1, bh = by1 - by0 + 1;

  // Marker-plane coordinates (a, b) of every pixel centre in the box, per pose; NaN = no hit.
  const int S = scene_.render.supersample;
  const float white = static_cast<float>(scene_.render.white);
  const float black = static_cast<float>(scene_.render.black);
  cv::Mat acc(bh, bw, CV_32F, cv::Scalar(0));
  cv::Mat ab(bh, bw, CV_32FC2);
  cv::Mat region(bh, bw, CV_8S);
  for (std::size_t k = 0; k < pm.poses.size(); ++k) {
    const MarkerPose& pose = pm.poses[k];
    const SceneCamera& cam = cam_of(k);
    const Eigen::Matrix3d R = cam.R_wc;
    // The ray of each pixel meets the marker's plane (normal n through its centre) at t; the
    // hit's coordinates along the marker axes are (a, b) in marker units.
    const Eigen::Matrix3d f = pose.frame();
    const Eigen::Vector3d centre(pose.x, pose.y, pose.z);
    const Eigen::Vector3d n = f.col(2);
    const double plane = n.dot(centre - cam.position);
    for (int y = 0; y < bh; ++y) {
      const auto* uv = uv_->ptr<cv::Vec2f>(by0 + y) + bx0;
      auto* out = ab.ptr<cv::Vec2f>(y);
      for (int x = 0; x < bw; ++x) {
        const Eigen::Vector3d d = R * Eigen::Vector3d(uv[x][0], uv[x][1], 1.0);
        const double t = plane / n.dot(d);
        if (!(t > 0)) {
          out[x] = {kNaNf, kNaNf};
          continue;
        }
        const Eigen::Vector3d q = cam.position + t * d - centre;
        out[x] = {static_cast<float>(f.col(0).dot(q) / mk.length), static_cast<float>(f.col(1).dot(q) / mk.length)};
      }
    }
    // Region of every pixel centre: a cell of the pattern, the white margin, or off the plate.
    auto region_of = [&](double a, double b) -> int {
      if (!(std::abs(a) <= half_plate && std::abs(b) <= half_plate)) return kOffPlate;  // also NaN
      if (std::abs(a) >= 0.5 || std::abs(b) >= 0.5) return kMargin;
      const int col = std::min(cells - 1, static_cast<int>((a + 0.5) * cells));
      const int row = std::min(cells - 1, static_cast<int>((0.5 - b) * cells));
      return pattern.at<std::uint8_t>(row, col) == 0 ? kBlack : kWhite;
    };
    for (int y = 0; y < bh; ++y) {
      const auto* r = ab.ptr<cv::Vec2f>(y);
      auto* g = region.ptr<std::int8_t>(y);
      for (int x = 0; x < bw; ++x) g[x] = static_cast<std::int8_t>(region_of(r[x][0], r[x][1]));
    }
    auto value_of = [&](int reg, float bg_value, float gain) -> float {
      switch (reg) {
        case kBlack: return black * gain;
        case kWhite:
        case kMargin: return white * gain;
        default: return bg_value;  // off the plate (or no ray): what was there
      }
    };
    for (int y = 0; y < bh; ++y) {
      const auto* bg = gray.ptr<std::uint8_t>(by0 + y) + bx0;
      const float* gain = gain_.ptr<float>(by0 + y) + bx0;
      float* a_out = acc.ptr<float>(y);
      const auto* reg = region.ptr<std::int8_t>(y);
      for (int x = 0; x < bw; ++x) {
        // A pixel whose centre and diagonal neighbours' centres share a region lies wholly
        // inside it (regions are convex and the mapping is smooth): no supersampling needed.
        if (y > 0 && y + 1 < bh && x > 0 && x + 1 < bw) {
          const int here = reg[x];
          const auto* up = region.ptr<std::int8_t>(y - 1);
          const auto* dn = region.ptr<std::int8_t>(y + 1);
          if (up[x - 1] == here && up[x + 1] == here && dn[x - 1] == here && dn[x + 1] == here) {
            a_out[x] += value_of(here, bg[x], gain[x]);
            continue;
          }
        }
        // Supersample: sub-pixel marker coordinates by bilinear interpolation of the centres.
        float sum = 0.0f;
        for (int sy = 0; sy < S; ++sy) {
          const double fy = y + (sy + 0.5) / S - 0.5;
          for (int sx = 0; sx < S; ++sx) {
            const cv::Vec2d ab_at = plane_coords_at(ab, x + (sx + 0.5) / S - 0.5, fy);
            const double a = ab_at[0], b = ab_at[1];
            sum += value_of(region_of(a, b), bg[x], gain[x]);
          }
        }
        a_out[x] += sum / static_cast<float>(S * S);
      }
    }
  }
  const float inv = 1.0f / static_cast<float>(pm.poses.size());
  for (int y = 0; y < bh; ++y) {
    auto* g = gray.ptr<std::uint8_t>(by0 + y) + bx0;
    const float* a = acc.ptr<float>(y);
    for (int x = 0; x < bw; ++x) g[x] = cv::saturate_cast<std::uint8_t>(a[x] * inv);
  }
}

}  // namespace ips::sim
