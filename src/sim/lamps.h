// Ceiling lamps in a frame of a camera looking up (src/sim/lamps.cpp): drawn before the
// markers, over the plain ceiling, before the sensor noise.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "ips/sim/scene.h"

namespace ips::sim {

/// Draws every lamp (and its glow) that `cam` sees into `gray` (CV_8U). `rays`: the camera's
/// normalised coordinates per pixel (CameraRenderer::rays()); `gain`: its vignetting per pixel.
void draw_lamps(const std::vector<SceneLamp>& lamps, const SceneCamera& cam, const cv::Mat& rays, const cv::Mat& gain,
                cv::Mat& gray);

}  // namespace ips::sim
