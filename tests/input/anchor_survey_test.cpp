// The daemon's survey of its anchors (ips/input/anchor_survey.h) through the range fixer: a
// robot the cameras see drives a circle while its tag ranges to 4 anchors, one of which was
// mounted 15 cm from where the configuration says; the survey must find that one moved and
// the others where they are.
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "ips/input/range_fixer.h"
#include "ranging_lab.h"

namespace ips {
namespace {

TEST(AnchorSurvey, FindsTheAnchorThatIsNotWhereTheConfigurationSays) {
  RangingConfig c = test::ranging_lab();
  c.height = 0.3;
  std::map<std::uint32_t, Eigen::Vector3d> mounted;
  for (const auto& [id, a] : c.anchors) mounted[id] = a.position;
  mounted[2] += Eigen::Vector3d(-0.12, 0.09, 0.0);  // 15 cm along the floor from its configured place
  // The robot: a circle of r 1.3 m at 0.4 m/s, seen by the cameras at 30 fps (1 mm).
  const auto truth = [](double t) {
    const double a = 0.4 / 1.3 * t;
    return Eigen::Vector3d(2.0 + 1.3 * std::cos(a), 1.5 + 1.3 * std::sin(a), 0.3);
  };
  std::int64_t now = 0;
  RangeFixer fixer(c, [&](const RangingTag& carrier) -> std::optional<MobileReference> {
    const int id = carrier.marker;
    if (id != 20) return std::nullopt;
    MobileReference m;
    m.t_mono_ns = (now / 33'333'333) * 33'333'333;
    const double t = 1e-9 * static_cast<double>(m.t_mono_ns);
    m.position = truth(t);
    m.velocity = (truth(t + 1e-3) - truth(t - 1e-3)) / 2e-3;
    m.covariance = 1e-6 * Eigen::Matrix3d::Identity();
    m.seen_by_cameras = true;
    return m;
  });
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<AnchorEvent> events;
  for (int i = 0; i < 1200; ++i) {  // 2 min at 10 Hz: 1200 samples per anchor
    now = static_cast<std::int64_t>(i) * 100'000'000;
    AdmittedFiring f;
    f.firing.tag = 7;
    f.firing.firing = static_cast<std::uint32_t>(i);
    f.t_mono_ns = now;
    for (const auto& [id, p] : mounted)
      f.firing.entries.push_back({id, false, (p - truth(1e-9 * static_cast<double>(now))).norm() + noise(rng), 0.02});
    fixer.fix(f, 0);
    for (const AnchorEvent& e : fixer.take_anchor_events()) events.push_back(e);
  }
  // The log's verdicts: the knocked anchor once, the others never.
  for (const AnchorEvent& e : events)
    std::printf("event: anchor %u %s, %.1f +- %.1f cm\n", e.anchor,
                e.kind == AnchorEvent::Kind::kMoved ? "moved" : "back", 100 * e.shift.norm(), 100 * e.sigma_m);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, AnchorEvent::Kind::kMoved);
  EXPECT_EQ(events[0].anchor, 2u);
  EXPECT_NEAR(events[0].shift.head<2>().norm(), 0.15, 0.03);
  EXPECT_LT(events[0].sigma_m, 0.05);
  const auto surveys = fixer.anchor_surveys();
  ASSERT_EQ(surveys.size(), 4u);
  for (const AnchorSurvey& s : surveys) {
    ASSERT_TRUE(s.calibration) << s.anchor;
    const AnchorCalibration& a = *s.calibration;
    std::printf("anchor %u: %llu samples, %s, estimated %s, %.1f cm from configured (truth %.1f), bias %+.1f cm\n",
                s.anchor, static_cast<unsigned long long>(s.samples), anchor_calibration_status_word(a.status),
                anchor_unknowns_word(a.unknowns), 100 * (a.position - s.configured).norm(),
                100 * (mounted[s.anchor] - s.configured).norm(), 100 * a.bias_m);
    EXPECT_EQ(s.samples, 1200u);
    ASSERT_EQ(a.status, AnchorCalibration::Status::kOk) << s.anchor;
    EXPECT_NE(a.unknowns, AnchorUnknowns::kBias) << s.anchor;
    // Where the survey placed it, against where it is mounted (horizontally: the tag moves in
    // one plane, so the height may be the configured one).
    EXPECT_LT((a.position - mounted[s.anchor]).head<2>().norm(), 0.03) << s.anchor;
  }
}

}  // namespace
}  // namespace ips
