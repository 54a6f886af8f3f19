#include "ips/fusion/fusion.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "frame_grouper.h"
#include "ips/core/error.h"
#include "ips/mapping/to_world.h"

namespace ips {
namespace {

WorldObservation obs(int id, int cam, double x, double y, double yaw, double area, std::int64_t t = 0) {
  WorldObservation o;
  o.id = id;
  o.camera_index = cam;
  o.p_world = {x, y, 0.1};
  o.yaw = yaw;
  o.area_px = area;
  o.t_mono_ns = t;
  o.t_real_ns = t + 1'000'000'000'000;
  return o;
}

TEST(Fusion, RegistryHasTheFourMethodsAndRefusesUnknownNamesListingThem) {
  std::vector<std::string> names;
  for (const auto& m : fusion_methods()) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"mean", "area", "gauss", "median"}));
  try {
    (void)find_fusion_method("avg", "ipsd.yaml: fusion.method");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find("fusion.method: unknown fusion method 'avg' (known: mean, area, gauss, median)"),
        std::string::npos)
        << e.what();
  }
}

TEST(Fusion, WeightedMeansMatchHandComputedValues) {
  const std::vector<WorldObservation> two = {obs(7, 0, 1.0, 0.0, 0.0, 100.0, 0),
                                             obs(7, 2, 3.0, 2.0, 0.0, 300.0, 20'000'000)};
  const auto mean = fuse_marker(two, find_fusion_method("mean", ""));
  EXPECT_DOUBLE_EQ(mean.p_world.x(), 2.0);
  EXPECT_DOUBLE_EQ(mean.p_world.y(), 1.0);
  EXPECT_EQ(mean.camera_mask, 0b101u);
  EXPECT_DOUBLE_EQ(mean.quality, 400.0);
  EXPECT_DOUBLE_EQ(mean.spread, std::sqrt(2.0));
  EXPECT_EQ(mean.t_mono_ns, 10'000'000);  // mean capture time
  EXPECT_EQ(mean.t_real_ns, 1'000'010'000'000);
  // area: weights 100/400, 300/400
  const auto area = fuse_marker(two, find_fusion_method("area", ""));
  EXPECT_DOUBLE_EQ(area.p_world.x(), 2.5);
  EXPECT_EQ(area.t_mono_ns, 15'000'000);
  // gauss: weights 1e4/1e5, 9e4/1e5
  const auto gauss = fuse_marker(two, find_fusion_method("gauss", ""));
  EXPECT_NEAR(gauss.p_world.x(), 2.8, 1e-12);
  EXPECT_NEAR(gauss.p_world.y(), 1.8, 1e-12);
}

TEST(Fusion, MedianIgnoresOneOutlierCamera) {
  const std::vector<WorldObservation> three = {obs(1, 0, 1.0, 5.0, 0.1, 1), obs(1, 1, 2.0, 5.2, 0.1, 1),
                                               obs(1, 2, 10.0, 5.1, 0.1, 1)};
  const auto med = fuse_marker(three, find_fusion_method("median", ""));
  EXPECT_DOUBLE_EQ(med.p_world.x(), 2.0);
  EXPECT_DOUBLE_EQ(med.p_world.y(), 5.1);
  EXPECT_EQ(med.camera_mask, 0b111u);
  EXPECT_DOUBLE_EQ(med.spread, 8.0);  // camera 2 at (10, 5.1) vs fused (2, 5.1)
}

TEST(Fusion, YawIsACircularMeanAcrossTheSeam) {
  const std::vector<WorldObservation> two = {obs(1, 0, 0, 0, 3.1, 1), obs(1, 1, 0, 0, -3.1, 1)};
  const auto f = fuse_marker(two, find_fusion_method("mean", ""));
  EXPECT_NEAR(std::abs(f.yaw), std::numbers::pi, 1e-12);  // not 0
}

TEST(Fusion, FuseGroupsByIdSortedById) {
  const std::vector<WorldObservation> mixed = {obs(9, 0, 1, 1, 0, 1), obs(2, 0, 5, 5, 0, 1), obs(9, 1, 3, 1, 0, 1)};
  const auto out = fuse(mixed, find_fusion_method("mean", ""));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].id, 2);
  EXPECT_EQ(out[0].camera_mask, 1u);
  EXPECT_EQ(out[1].id, 9);
  EXPECT_DOUBLE_EQ(out[1].p_world.x(), 2.0);
  EXPECT_EQ(out[1].camera_mask, 3u);
}

// A hand-made mapper: world = (2 * xc + 1, yc - 3, known height); non-rigid (stretches x).
class StretchMapper : public Mapper {
 public:
  std::string method() const override { return "stretch"; }
  void fit(std::span<const Eigen::Vector3d>, std::span<const Eigen::Vector3d>, const FitOptions&) override {}
  Eigen::Vector3d predict(const Eigen::Vector3d& c, double h) const override { return {2 * c.x() + 1, c.y() - 3, h}; }
  bool needs_height() const override { return true; }
  std::size_t min_points() const override { return 0; }
  nlohmann::json to_json() const override { return {}; }
  void from_json(const nlohmann::json&) override {}
};

TEST(Fusion, WorldHeadingFollowsTheMapperNotJustTheCameraYaw) {
  CameraObservation c;
  c.id = 4;
  c.p_cam = {0.5, 0.25, 2.0};
  c.yaw = std::numbers::pi / 4;  // (1, 1) in the camera frame -> (2, 1) in the world
  c.area_px = 900;
  const StretchMapper mapper;
  const auto w = to_world(c, mapper, 0.12, 2, 5, 6);
  EXPECT_DOUBLE_EQ(w.p_world.x(), 2.0);
  EXPECT_DOUBLE_EQ(w.p_world.y(), -2.75);
  EXPECT_DOUBLE_EQ(w.p_world.z(), 0.12);
  EXPECT_NEAR(w.yaw, std::atan2(1.0, 2.0), 1e-12);
  EXPECT_EQ(w.camera_index, 2);
  EXPECT_EQ(w.t_mono_ns, 5);
  EXPECT_EQ(w.t_real_ns, 6);
  EXPECT_DOUBLE_EQ(w.area_px, 900);
}

FrameObservations batch(int cam, std::int64_t t_ms) {
  FrameObservations b;
  b.camera_index = cam;
  b.t_mono_ns = t_ms * 1'000'000;
  return b;
}

TEST(FrameGrouper, ClosesASetWhenEveryExpectedCameraDelivered) {
  FrameGrouper g(20'000'000, 50'000'000);
  g.set_expected_cameras({0, 1, 2});
  std::vector<std::vector<FrameObservations>> done;
  g.add(batch(0, 100), 0, done);
  g.add(batch(2, 105), 1, done);
  EXPECT_TRUE(done.empty());
  g.add(batch(1, 110), 2, done);
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].size(), 3u);
  EXPECT_EQ(g.deadline_ns(), -1);
}

TEST(FrameGrouper, ABatchOutsideTheWindowOrARepeatedCameraStartsANewSet) {
  FrameGrouper g(20'000'000, 1'000'000'000);
  g.set_expected_cameras({0, 1, 2});
  std::vector<std::vector<FrameObservations>> done;
  g.add(batch(0, 100), 0, done);
  g.add(batch(1, 125), 0, done);  // 25 ms after the first: its own set
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].size(), 1u);
  g.add(batch(1, 130), 0, done);  // camera 1 again
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(done[1][0].t_mono_ns, 125'000'000);
}

TEST(FrameGrouper, AnIncompleteSetClosesAfterMaxWait) {
  FrameGrouper g(20'000'000, 30'000'000);
  g.set_expected_cameras({0, 1});
  std::vector<std::vector<FrameObservations>> done;
  g.add(batch(0, 100), 1'000, done);
  EXPECT_EQ(g.deadline_ns(), 30'001'000);
  g.poll(30'000'999, done);
  EXPECT_TRUE(done.empty());
  g.poll(30'001'000, done);
  ASSERT_EQ(done.size(), 1u);
}

}  // namespace
}  // namespace ips
