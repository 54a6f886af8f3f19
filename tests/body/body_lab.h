// A simulated lab for body tests: the published three-camera layout with the test's bodies,
// each camera's `plane` model fitted on exact simulated pairs, and one instant run through the
// real pipeline: render -> JPEG -> detect -> undistort -> marker pose -> body observation.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../daemon/plane_model.h"
#include "ips/body/body_estimate.h"
#include "ips/capture/jpeg_decoder.h"
#include "ips/detect/detector.h"
#include "ips/geometry/marker_geometry.h"
#include "ips/mapping/mapper.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"
#include "published_scene.h"

namespace ips::test {

#if defined(IPS_SANITIZED)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

class BodyLab {
 public:
  /// `bodies_yaml` starts with "bodies:"; the scene has no plain markers.
  BodyLab(const std::string& bodies_yaml, const std::string& dir) {
    const std::string path = dir + "/scene.yaml";
    {
      std::ofstream out(path);
      out << published_scene_with("markers: []\n" + bodies_yaml);
    }
    scene_ = std::make_shared<sim::Scene>(sim::Scene::load(path));
    for (std::size_t c = 0; c < scene_->cameras.size(); ++c) {
      renderers_.push_back(std::make_unique<sim::CameraRenderer>(*scene_, c));
      mappers_.push_back(fit_plane(*renderers_.back()));
    }
    std::vector<BodyDef> defs;
    for (const auto& b : scene_->bodies) defs.push_back(b.def);
    estimator_ = std::make_unique<BodyEstimator>(defs);
  }

  const sim::Scene& scene() const { return *scene_; }
  BodyEstimator& estimator() { return *estimator_; }
  const Mapper& mapper(std::size_t c) const { return *mappers_[c]; }
  const sim::CameraRenderer& renderer(std::size_t c) const { return *renderers_[c]; }

  /// Observations of every camera at scene time t (frame index k for the noise); per camera,
  /// the ids it detected go to `seen[camera]`.
  std::vector<BodyObservation> observe(double t, std::uint64_t k, std::vector<std::vector<int>>* seen = nullptr) {
    std::vector<BodyObservation> out;
    const auto t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));  // the estimator's yaw memory runs on it
    if (seen) seen->assign(renderers_.size(), {});
    for (std::size_t c = 0; c < renderers_.size(); ++c) {
      const sim::CameraRenderer& r = *renderers_[c];
      r.render(t, gray_, k * 7 + c);
      const auto jpeg = sim::encode_jpeg(gray_, scene_->render.jpeg_quality, false);
      decoder_.decode_gray(jpeg, decoded_);
      for (const MarkerDetection& d : detector_.detect(decoded_, &r.camera().model)) {
        const int b = estimator_->body_of(d.id);
        if (b < 0) continue;
        double edge = 0;
        for (const auto& m : estimator_->bodies()[static_cast<std::size_t>(b)].markers)
          if (m.id == d.id) edge = m.edge;
        const CameraObservation obs = locate_marker(d, r.camera().model, edge);
        BodyObservation bo;
        std::string why;
        const bool ok = estimator_->observe(obs, *mappers_[c], static_cast<int>(c), t_ns, t_ns, bo, &why);
        if (!ok && std::getenv("IPS_BODY_LOOP_DEBUG"))
          std::printf("  t %.2f camera %zu id %d rejected: %s\n", t, c, d.id, why.c_str());
        if (ok) {
          out.push_back(bo);
          if (seen) (*seen)[c].push_back(d.id);
        }
      }
    }
    return out;
  }

 private:
  static std::unique_ptr<Mapper> fit_plane(const sim::CameraRenderer& renderer) {
    std::mt19937_64 rng(7);  // each camera from the same seed
    return fit_plane_on_exact_pairs(renderer, rng);
  }

  std::shared_ptr<sim::Scene> scene_;
  std::vector<std::unique_ptr<sim::CameraRenderer>> renderers_;
  std::vector<std::unique_ptr<Mapper>> mappers_;
  std::unique_ptr<BodyEstimator> estimator_;
  Detector detector_;
  JpegDecoder decoder_;
  cv::Mat gray_, decoded_;
};

inline double wrap_angle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

/// The p-quantile (0..1) of values (copied, nearest rank).
inline double quantile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1;
  return v[std::min(i, v.size() - 1)];
}

}  // namespace ips::test
