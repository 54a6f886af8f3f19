#include "ips/geometry/marker_geometry.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace {

const std::filesystem::path kData = IPS_TEST_DATA_DIR;

// A marker of edge L at camera-frame centre (X, Y, Z), parallel to the image plane, with its
// x-axis at angle `yaw` in the camera x-y plane: project its corners exactly, then the
// formula must give back X, Y, Z and yaw (the formula is exact for a fronto-parallel square).
TEST(LocateMarker, RecoversFrontoParallelMarkerExactly) {
  const auto cam = ips::CameraModel::load(kData / "ou2023/intrinsics_red.yaml");
  const double L = 0.2;
  for (const auto& [X, Y, Z, yaw] :
       {std::tuple{0.0, 0.0, 2.1, 0.0}, std::tuple{0.8, -0.4, 1.95, 0.7}, std::tuple{-1.1, 0.5, 2.0, -2.5}}) {
    ips::MarkerDetection det;
    det.id = 7;
    // Corners TL, TR, BR, BL in the marker frame (x right, y up as printed); the camera's
    // y axis points the other way to the marker's printed "up" when seen from the front.
    const double h = L / 2;
    const double local[4][2] = {{-h, h}, {h, h}, {h, -h}, {-h, -h}};
    for (int i = 0; i < 4; ++i) {
      const double mx = local[i][0];
      const double my = -local[i][1];  // printed up = camera -y
      const double cx = X + std::cos(yaw) * mx - std::sin(yaw) * my;
      const double cy = Y + std::sin(yaw) * mx + std::cos(yaw) * my;
      det.corners_px[static_cast<std::size_t>(i)] = cam.project({cx / Z, cy / Z});
    }
    const auto obs = ips::locate_marker(det, cam, L);
    EXPECT_EQ(obs.id, 7);
    EXPECT_NEAR(obs.p_cam.x(), X, 1e-9);
    EXPECT_NEAR(obs.p_cam.y(), Y, 1e-9);
    EXPECT_NEAR(obs.p_cam.z(), Z, 1e-9);
    EXPECT_NEAR(std::remainder(obs.yaw - yaw, 2 * std::numbers::pi), 0.0, 1e-9);
    EXPECT_DOUBLE_EQ(obs.edge_length, L);
    EXPECT_GT(obs.area_px, 0.0);
  }
}

TEST(LocateMarker, ShoelaceAreaAndPublishedRow) {
  EXPECT_DOUBLE_EQ(ips::polygon_area_px({{{0, 0}, {10, 0}, {10, 5}, {0, 5}}}), 50.0);
  EXPECT_DOUBLE_EQ(ips::polygon_area_px({{{0, 0}, {0, 5}, {10, 5}, {10, 0}}}), 50.0);
  // Normalised square of side 0.1 centred at (0.2, -0.1), L = 0.2 -> zc = 4L / 0.4 = 2.
  ips::CameraObservation o;
  o.edge_length = 0.2;
  o.corners_norm = {{{0.15, -0.15}, {0.25, -0.15}, {0.25, -0.05}, {0.15, -0.05}}};
  const auto r = ips::locate_from_normalised(o);
  EXPECT_DOUBLE_EQ(r.p_cam.z(), 2.0);
  EXPECT_NEAR(r.p_cam.x(), 0.4, 1e-12);
  EXPECT_NEAR(r.p_cam.y(), -0.2, 1e-12);
  EXPECT_NEAR(r.yaw, 0.0, 1e-12);
}

}  // namespace
