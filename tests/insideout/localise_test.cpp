// Inside-out localisation against corners projected exactly through a real fisheye lens (the
// published red camera's calibration) from a known robot pose: the pose comes back exactly,
// its covariance matches the scatter noise makes, and a wrong map entry is left out.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "ips/insideout/localise.h"

namespace ips {
namespace {

const CameraModel& lens() {
  static const CameraModel m = CameraModel::load(std::string(IPS_TEST_DATA_DIR) + "/ou2023/intrinsics_red.yaml");
  return m;
}

// A 3 x 3 grid of 0.25 m markers 2.8 m up, 1.2 m apart, turned every which way.
CeilingMap grid_map() {
  CeilingMap map;
  int id = 0;
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      CeilingMarker m;
      m.id = id;
      m.centre = {1.0 + 1.2 * i, 1.0 + 1.2 * j, 2.8};
      m.yaw = 0.7 * id - 2.0;
      m.length = 0.25;
      map.markers.push_back(m);
      ++id;
    }
  }
  return map;
}

struct Truth {
  Eigen::Vector3d position;  // robot origin
  double yaw;
  double roll = 0, pitch = 0;  // the floor's tilt under the robot
  Eigen::Matrix3d axes() const {
    return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
  }
};

// What the camera sees: every map marker whose corners all project, with Gaussian noise.
std::vector<MarkerDetection> observe(const CeilingMap& map, const Truth& t, const CameraMount& mount, double noise,
                                     std::mt19937& rng) {
  const Eigen::Matrix3d R_wr = t.axes();
  const Eigen::Matrix3d R_wc = R_wr * mount.camera_axes();
  const Eigen::Vector3d c = t.position + R_wr * mount.offset;
  std::normal_distribution<double> n(0.0, noise);
  std::vector<MarkerDetection> out;
  for (const auto& m : map.markers) {
    MarkerDetection d;
    d.id = m.id;
    bool ok = true;
    const auto corners = m.corners();
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d pc = R_wc.transpose() * (corners[k] - c);
      if (!(pc.z() > 0) || std::atan2(std::hypot(pc.x(), pc.y()), pc.z()) > 1.3) ok = false;
      const Point2 px = lens().project({pc.x() / pc.z(), pc.y() / pc.z()});
      d.corners_px[k] = {px.x + (noise > 0 ? n(rng) : 0.0), px.y + (noise > 0 ? n(rng) : 0.0)};
    }
    if (ok) out.push_back(d);
  }
  return out;
}

TEST(Localise, ExactCornersGiveTheExactPoseOnATiltedFloor) {
  const CeilingMap map = grid_map();
  std::mt19937 rng(1);
  const CameraMount mount;  // lens at the origin, looking up, image x forward
  LocaliseOptions free;     // no level-floor prior: the exact answer, tilt included
  free.tilt_sigma = 0;
  for (const Truth& t : {Truth{{2.2, 2.2, 0.3}, 0.0}, Truth{{1.6, 3.1, 0.25}, 2.5, 0.03, -0.02},
                         Truth{{3.7, 0.6, 0.4}, -1.9, -0.01, 0.04}}) {
    const auto seen = observe(map, t, mount, 0.0, rng);
    ASSERT_GE(seen.size(), 3u);
    // With the prior (a level floor within 1 degree) a 2-degree lean of nine markers' view
    // costs under a millimetre.
    const Localisation prior = localise(seen, lens(), map, mount);
    ASSERT_TRUE(prior.ok) << prior.why;
    EXPECT_LT((prior.pose.position - t.position).norm(), 0.001);
    const Localisation l = localise(seen, lens(), map, mount, free);
    ASSERT_TRUE(l.ok) << l.why;
    EXPECT_LT((l.pose.position - t.position).norm(), 1e-6);
    EXPECT_LT(std::abs(std::remainder(l.pose.yaw - t.yaw, 2 * M_PI)), 1e-7);
    EXPECT_LT((l.pose.axes - t.axes()).norm(), 1e-6);  // the tilt too
    EXPECT_LT(l.rms_px, 1e-4);
    EXPECT_EQ(l.used.size(), seen.size());
    EXPECT_TRUE(l.rejected.empty());
  }
}

TEST(Localise, TheMountIsTakenOffToGiveTheRobotsOrigin) {
  const CeilingMap map = grid_map();
  std::mt19937 rng(2);
  CameraMount mount;
  mount.offset = {0.15, -0.05, 0.32};  // lens ahead of and right of the origin, 32 cm up
  mount.yaw = M_PI / 2;                // image +x points to the robot's left
  mount.pitch = 0.05;                  // and the camera leans a little
  const Truth t{{2.5, 1.9, 0.0}, 0.8};
  LocaliseOptions free;
  free.tilt_sigma = 0;
  const Localisation l = localise(observe(map, t, mount, 0.0, rng), lens(), map, mount, free);
  ASSERT_TRUE(l.ok) << l.why;
  EXPECT_LT((l.pose.position - t.position).norm(), 1e-6);
  EXPECT_NEAR(l.pose.yaw, 0.8, 1e-7);
  EXPECT_LT((l.pose.camera_position - (t.position + t.axes() * mount.offset)).norm(), 1e-6);
}

TEST(Localise, OneMarkerAlonePlacesTheRobotWithinItsReportedSigma) {
  CeilingMap map = grid_map();
  std::mt19937 rng(3);
  const CameraMount mount;
  // Under marker 4 (the centre of the grid), nearly fronto-parallel: IPPE's two solutions are
  // closest there; the one with the camera upright must win.
  const Truth t{{2.3, 2.1, 0.3}, 1.1};
  auto seen = observe(map, t, mount, 0.1, rng);
  std::erase_if(seen, [](const MarkerDetection& d) { return d.id != 4; });
  ASSERT_EQ(seen.size(), 1u);
  const Localisation l = localise(seen, lens(), map, mount);
  ASSERT_TRUE(l.ok) << l.why;
  // A 1-degree lean moves the ceiling 4.4 cm across a camera 2.5 m below it, and one small
  // marker's perspective hardly tells a lean from a shift: the level-floor prior (1 degree)
  // bounds it, and the reported sigma says so.
  const double sx = std::sqrt(l.pose.covariance(0, 0)), sy = std::sqrt(l.pose.covariance(1, 1));
  EXPECT_GT(sx, 0.02);
  EXPECT_LT(sx, 0.06);
  EXPECT_LT(std::abs(l.pose.position.x() - t.position.x()), 3 * sx);
  EXPECT_LT(std::abs(l.pose.position.y() - t.position.y()), 3 * sy);
  EXPECT_LT(std::abs(std::remainder(l.pose.yaw - t.yaw, 2 * M_PI)), 0.01);
  // Without the prior, only the marker's perspective: far less certain.
  LocaliseOptions free;
  free.tilt_sigma = 0;
  const Localisation f = localise(seen, lens(), map, mount, free);
  ASSERT_TRUE(f.ok) << f.why;
  EXPECT_GT(std::sqrt(f.pose.covariance(0, 0)), 2 * sx);
}

TEST(Localise, TheCovarianceMatchesTheScatterOfNoisyCorners) {
  const CeilingMap map = grid_map();
  std::mt19937 rng(4);
  const CameraMount mount;
  const Truth t{{2.9, 2.4, 0.3}, 0.4};
  LocaliseOptions options;
  options.pixel_sigma = 0.3;
  Eigen::Vector4d sum = Eigen::Vector4d::Zero(), sum2 = Eigen::Vector4d::Zero();
  Eigen::Matrix4d predicted = Eigen::Matrix4d::Zero();
  constexpr int kTrials = 400;
  for (int i = 0; i < kTrials; ++i) {
    const Localisation l = localise(observe(map, t, mount, 0.3, rng), lens(), map, mount, options);
    ASSERT_TRUE(l.ok) << l.why;
    const Eigen::Vector4d e(l.pose.position.x() - t.position.x(), l.pose.position.y() - t.position.y(),
                            l.pose.position.z() - t.position.z(), std::remainder(l.pose.yaw - t.yaw, 2 * M_PI));
    sum += e;
    sum2 += e.cwiseProduct(e);
    predicted += l.pose.covariance / kTrials;
  }
  for (int k = 0; k < 4; ++k) {
    const double mean = sum[k] / kTrials;
    const double sd = std::sqrt(sum2[k] / kTrials - mean * mean);
    const double expected = std::sqrt(predicted(k, k));
    // 400 trials: the sample sd is within ~7 % of the truth at 2 sigma; 20 % leaves room.
    EXPECT_NEAR(sd / expected, 1.0, 0.2) << "coordinate " << k << ": sd " << sd << " predicted " << expected;
    EXPECT_LT(std::abs(mean), 4 * expected / std::sqrt(kTrials)) << "coordinate " << k << " biased";
  }
}

TEST(Localise, AMarkerMovedSinceMappingIsLeftOutAndNamed) {
  CeilingMap map = grid_map();
  std::mt19937 rng(5);
  const CameraMount mount;
  const Truth t{{2.2, 2.2, 0.3}, -0.6};
  const auto seen = observe(map, t, mount, 0.1, rng);
  // The map still has marker 5 where it was; someone moved it 20 cm since.
  CeilingMap stale = map;
  stale.markers[5].centre.x() -= 0.20;
  MarkerDetection stranger{42, seen[0].corners_px};  // an id the map does not have
  auto with_stranger = seen;
  with_stranger.push_back(stranger);
  const Localisation l = localise(with_stranger, lens(), stale, mount);
  ASSERT_TRUE(l.ok) << l.why;
  EXPECT_EQ(l.rejected, std::vector<int>{5});
  EXPECT_EQ(l.unknown, std::vector<int>{42});
  EXPECT_EQ(std::count(l.used.begin(), l.used.end(), 5), 0);
  EXPECT_LT((l.pose.position - t.position).norm(), 0.003);
}

TEST(Localise, NoKnownMarkerSaysSo) {
  const CeilingMap map = grid_map();
  const Localisation none = localise({}, lens(), map, CameraMount{});
  EXPECT_FALSE(none.ok);
  EXPECT_EQ(none.why, "no marker in view");
  const std::vector<MarkerDetection> strangers{{77, {Point2{900, 500}, {950, 500}, {950, 550}, {900, 550}}}};
  const Localisation l = localise(strangers, lens(), map, CameraMount{});
  EXPECT_FALSE(l.ok);
  EXPECT_EQ(l.why, "no marker of the map in view");
  EXPECT_EQ(l.unknown, std::vector<int>{77});
  // Corners that no pose explains (a square seen as a bow tie): refused, not a wild pose.
  const std::vector<MarkerDetection> twisted{{4, {Point2{900, 500}, {950, 550}, {950, 500}, {900, 550}}}};
  const Localisation w = localise(twisted, lens(), map, CameraMount{});
  EXPECT_FALSE(w.ok);
  EXPECT_FALSE(w.why.empty());
}

}  // namespace
}  // namespace ips
