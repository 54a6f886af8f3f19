// Ceiling lamps: parsed from the scene's `lamps:` and drawn for cameras looking up. Each pixel
// near a lamp casts its ray to the lamp's ceiling plane; inside the disc or panel it is the
// lamp's brightness, around it the glow fades linearly over glare_width. Exact for a riding
// camera at any pose; drawn at the frame's capture time only (no motion blur of lamps).
#include "sim/lamps.h"

#include <algorithm>
#include <cmath>

#include "sim/scene_reader.h"

namespace ips::sim {

void read_lamps(const SceneReader& r, const YAML::Node& root, Scene& scene) {
  const YAML::Node ls = root["lamps"];
  if (!ls) return;
  if (!ls.IsSequence()) r.fail(ls, "lamps", "expected a list");
  for (std::size_t i = 0; i < ls.size(); ++i) {
    const YAML::Node l = ls[i];
    const std::string p = "lamps[" + std::to_string(i) + "].";
    r.only_keys(l, p, {"x", "y", "height", "radius", "size", "yaw_deg", "brightness", "glare", "glare_width"});
    SceneLamp lamp;
    lamp.centre = {r.number(l, p, "x", 0, true), r.number(l, p, "y", 0, true), r.number(l, p, "height", 0, true)};
    if (!(lamp.centre.z() > 0 && lamp.centre.z() <= 50)) r.fail(l["height"], p + "height", "must be in (0, 50] m");
    if (l["radius"] && l["size"]) r.fail(l, p + "radius", "a lamp is a disc (radius) or a panel (size), not both");
    if (l["radius"]) {
      lamp.radius = r.number(l, p, "radius", 0);
      if (!(lamp.radius > 0 && lamp.radius <= 5)) r.fail(l["radius"], p + "radius", "must be in (0, 5] m");
    } else if (l["size"]) {
      const auto s = r.numbers(l, p, "size", 2, 2);
      if (!(s[0] > 0 && s[1] > 0 && s[0] <= 10 && s[1] <= 10)) r.fail(l["size"], p + "size", "must be in (0, 10] m");
      lamp.size_x = s[0];
      lamp.size_y = s[1];
    } else {
      r.fail(l, p + "radius", "missing: a disc needs radius, a panel size: [x, y]");
    }
    lamp.yaw = r.number(l, p, "yaw_deg", 0) * M_PI / 180.0;
    lamp.brightness = r.number(l, p, "brightness", lamp.brightness);
    if (!(lamp.brightness >= 0 && lamp.brightness <= 255)) r.fail(l["brightness"], p + "brightness", "must be 0..255");
    lamp.glare = r.number(l, p, "glare", lamp.glare);
    if (!(lamp.glare >= 0 && lamp.glare <= 1)) r.fail(l["glare"], p + "glare", "must be 0..1");
    lamp.glare_width = r.number(l, p, "glare_width", lamp.glare_width);
    if (!(lamp.glare_width >= 0 && lamp.glare_width <= 10))
      r.fail(l["glare_width"], p + "glare_width", "must be 0..10 m");
    scene.lamps.push_back(lamp);
  }
}

namespace lamp_drawing {

/// How far a ceiling point (lamp frame) is outside the lamp, m (0 inside).
double outside_by(const SceneLamp& lamp, double lx, double ly) {
  if (lamp.radius > 0) return std::max(0.0, std::hypot(lx, ly) - lamp.radius);
  return std::hypot(std::max(0.0, std::abs(lx) - lamp.size_x / 2), std::max(0.0, std::abs(ly) - lamp.size_y / 2));
}

/// The pixel box the lamp and its glow can cover in `cam` (empty if behind it); the whole
/// image when part of it is out of the lens' reach (its outline cannot be projected).
cv::Rect pixel_box(const SceneLamp& lamp, const SceneCamera& cam, const cv::Size& size) {
  const double reach = (lamp.radius > 0 ? lamp.radius : 0.5 * std::hypot(lamp.size_x, lamp.size_y)) + lamp.glare_width;
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  int behind = 0;
  constexpr int kSteps = 32;
  for (int k = 0; k < kSteps; ++k) {
    const double a = 2 * M_PI * k / kSteps;
    const Eigen::Vector3d pc = cam.world_to_camera(lamp.centre + reach * Eigen::Vector3d(std::cos(a), std::sin(a), 0));
    const double theta = std::atan2(std::hypot(pc.x(), pc.y()), pc.z());
    if (pc.z() <= 1e-6 || theta >= cam.model.max_theta()) {
      ++behind;
      continue;
    }
    const Point2 px = cam.model.project({pc.x() / pc.z(), pc.y() / pc.z()});
    x0 = std::min(x0, px.x), y0 = std::min(y0, px.y), x1 = std::max(x1, px.x), y1 = std::max(y1, px.y);
  }
  const cv::Rect whole(0, 0, size.width, size.height);
  if (behind == kSteps) {
    // The whole circle is out of reach: the lamp is behind the camera, or it surrounds it.
    const Eigen::Vector3d c = cam.world_to_camera(lamp.centre);
    return c.z() > 0 ? whole : cv::Rect();
  }
  if (behind > 0) return whole;
  // A wide pinhole lens can put a point near its field's edge millions of pixels out: clamp
  // before the conversion to int (out of int's range it would be undefined).
  const auto clamp = [](double v) { return std::clamp(v, -1e6, 1e6); };
  x0 = clamp(x0), y0 = clamp(y0), x1 = clamp(x1), y1 = clamp(y1);
  const cv::Rect box(cv::Point(static_cast<int>(std::floor(x0)) - 2, static_cast<int>(std::floor(y0)) - 2),
                     cv::Point(static_cast<int>(std::ceil(x1)) + 3, static_cast<int>(std::ceil(y1)) + 3));
  return box & whole;
}

}  // namespace lamp_drawing

void draw_lamps(const std::vector<SceneLamp>& lamps, const SceneCamera& cam, const cv::Mat& rays, const cv::Mat& gain,
                cv::Mat& gray) {
  if (!cam.looks_up) return;  // a lamp faces the floor: only a camera looking up sees it
  for (const SceneLamp& lamp : lamps) {
    if (lamp.centre.z() <= cam.position.z()) continue;
    const cv::Rect box = lamp_drawing::pixel_box(lamp, cam, gray.size());
    if (box.empty()) continue;
    const double c = std::cos(lamp.yaw), s = std::sin(lamp.yaw);
    cv::parallel_for_(cv::Range(box.y, box.y + box.height), [&](const cv::Range& rows) {
      for (int y = rows.start; y < rows.end; ++y) {
        const auto* uv = rays.ptr<cv::Vec2f>(y);
        const auto* g = gain.ptr<float>(y);
        auto* out = gray.ptr<std::uint8_t>(y);
        for (int x = box.x; x < box.x + box.width; ++x) {
          if (std::isnan(uv[x][0])) continue;
          const Eigen::Vector3d d = cam.R_wc * Eigen::Vector3d(uv[x][0], uv[x][1], 1.0);
          if (d.z() <= 1e-9) continue;
          const Eigen::Vector3d hit = cam.position + (lamp.centre.z() - cam.position.z()) / d.z() * d;
          const double dx = hit.x() - lamp.centre.x(), dy = hit.y() - lamp.centre.y();
          const double off = lamp_drawing::outside_by(lamp, c * dx + s * dy, -s * dx + c * dy);
          if (off <= 0) {
            out[x] = cv::saturate_cast<std::uint8_t>(std::max<double>(out[x], lamp.brightness));
          } else if (off < lamp.glare_width) {
            const double glow = lamp.glare * lamp.brightness * (1.0 - off / lamp.glare_width) * g[x];
            out[x] = cv::saturate_cast<std::uint8_t>(out[x] + glow);
          }
        }
      }
    });
  }
}

}  // namespace ips::sim
