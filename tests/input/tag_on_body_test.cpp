// Where a tag sits on its carrier (docs/ranging.md "Tags on bodies"): the point on a moving,
// turning body (hand-computed), a body tag's fix (no marker id: the daemon places the body with
// it), a body's tag as another robot's mobile anchor, and a tag above a marker's centre.
#include <cmath>
#include <optional>

#include <gtest/gtest.h>

#include "ips/input/range_fixer.h"
#include "ranging_lab.h"

namespace ips {
namespace {

TEST(TagOnBody, ThePointMovesWithTheOriginAndTurnsWithTheBody) {
  MobileReference origin;
  origin.position = {1.0, 2.0, 0.0};
  origin.velocity = {0.5, 0.0, 0.0};
  origin.covariance = 4e-6 * Eigen::Matrix3d::Identity();
  origin.t_mono_ns = 123;
  origin.seen_by_cameras = true;
  // Heading 90 deg: the body's x axis is world +y. Turning at 2 rad/s.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  const MobileReference tag = point_on_body(origin, q, 2.0, {0.3, 0.0, 0.1});
  // Arm = (0, 0.3, 0.1): at (1.0, 2.3, 0.1); the turn adds (0, 0, 2) x (0, 0.3, 0.1) = (-0.6, 0, 0).
  EXPECT_NEAR(tag.position.x(), 1.0, 1e-12);
  EXPECT_NEAR(tag.position.y(), 2.3, 1e-12);
  EXPECT_NEAR(tag.position.z(), 0.1, 1e-12);
  EXPECT_NEAR(tag.velocity.x(), -0.1, 1e-12);
  EXPECT_NEAR(tag.velocity.y(), 0.0, 1e-12);
  EXPECT_NEAR(tag.velocity.z(), 0.0, 1e-12);
  EXPECT_EQ(tag.covariance, origin.covariance);
  EXPECT_EQ(tag.t_mono_ns, 123);
  EXPECT_TRUE(tag.seen_by_cameras);
}

RangingTag on_body(const char* name) {
  RangingTag t;
  t.body = name;
  t.offset = {0.0, 0.0, 0.3};
  return t;
}

TEST(TagOnBody, ABodyTagsFixNamesNoMarkerAndItsRobotIsAnotherTagsMobileAnchor) {
  RangingConfig c = test::ranging_lab();
  c.track = false;  // each firing alone: what one firing's references give
  c.tags[9] = on_body("long");
  const Eigen::Vector3d body_tag(3.0, 2.0, 0.3), tag(1.0, 1.0, 0.5);
  // Tag 9's own firing: its fix is the tag's point, for the daemon to place body "long" with.
  AdmittedFiring own;
  own.firing.tag = 9;
  own.t_mono_ns = 5'000'000'000;
  for (const auto& [id, a] : c.anchors) own.firing.entries.push_back({id, false, (a.position - body_tag).norm(), 0.0});
  int asked_for_the_body = 0;
  RangeFixer fixer(c, [&](const RangingTag& carrier) -> std::optional<MobileReference> {
    if (!carrier.on_body() || carrier.body != "long") return std::nullopt;
    ++asked_for_the_body;
    EXPECT_EQ(carrier.offset, Eigen::Vector3d(0, 0, 0.3));
    MobileReference r;  // the daemon's LatestStates: the body's pose moved to its tag
    r.position = body_tag;
    r.covariance = 1e-6 * Eigen::Matrix3d::Identity();
    r.t_mono_ns = own.t_mono_ns - 50'000'000;
    r.seen_by_cameras = true;
    return r;
  });
  const auto fix = fixer.fix(own, 0);
  ASSERT_TRUE(fix.has_value());
  EXPECT_EQ(fix->id, -1) << "a body's tag is published as its body, not as a marker";
  EXPECT_EQ(fix->camera_index, 9);
  EXPECT_LT((fix->p_world - body_tag).norm(), 1e-6);
  // Tag 7 ranges to three anchors and to tag 9: the body's tag is the fourth reference.
  AdmittedFiring other;
  other.firing.tag = 7;
  other.t_mono_ns = own.t_mono_ns;
  for (const auto& [id, a] : c.anchors)
    if (other.firing.entries.size() < 3) other.firing.entries.push_back({id, false, (a.position - tag).norm(), 0.0});
  other.firing.entries.push_back({9, true, (body_tag - tag).norm(), 0.0});
  const auto o = fixer.fix(other, 0);
  ASSERT_TRUE(o.has_value());
  EXPECT_LT((o->p_world - tag).norm(), 1e-6);
  EXPECT_EQ(o->id, 20);
  EXPECT_EQ(fixer.counters().mobile_references, 1u);
  EXPECT_GE(asked_for_the_body, 1);
}

// A tag 0.15 m above its marker's centre: the camera-placed marker, raised, is where the tag is;
// the tag's fix, lowered, is where the marker is.
TEST(TagOnMarker, ItsHeightRaisesTheMarkersStateAndLowersItsFix) {
  RangingConfig c = test::ranging_lab();
  c.track = false;
  c.tags[7].height = 0.15;
  MobileReference marker;
  marker.position = {1.0, 2.0, 0.15};
  marker.velocity = {0.3, 0, 0};
  const MobileReference tag = tag_point(marker, Eigen::Quaterniond::Identity(), 5.0, c.tags[7]);
  EXPECT_EQ(tag.position, Eigen::Vector3d(1.0, 2.0, 0.30));
  EXPECT_EQ(tag.velocity, marker.velocity) << "a marker's turn does not move a tag above its centre";
  const Eigen::Vector3d at(1.5, 1.2, 0.45);
  AdmittedFiring f;
  f.firing.tag = 7;
  f.t_mono_ns = 1'000'000'000;
  for (const auto& [id, a] : c.anchors) f.firing.entries.push_back({id, false, (a.position - at).norm(), 0.0});
  const auto o = RangeFixer(c).fix(f, 0);
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(o->id, 20);
  EXPECT_LT((o->p_world - Eigen::Vector3d(1.5, 1.2, 0.30)).norm(), 1e-6);
}

}  // namespace
}  // namespace ips
