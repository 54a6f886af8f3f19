// An anchor's position and bias from ranges at known tag positions, against the exact anchor
// the ranges were computed from: exact ranges, noisy ones with non-line-of-sight outliers,
// tags that never moved (the geometry cannot say where the anchor is), and the bias alone.
#include "ips/ranging/anchor_calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace ips {
namespace {

// The anchor as mounted: 12 cm along the wall, 18 cm higher and 3 cm out from where the
// configuration says (6, 0, 1.2), its module reading 7 cm long.
const Eigen::Vector3d kConfigured(6.0, 0.0, 1.2);
const Eigen::Vector3d kTrue(6.12, 0.03, 1.38);
constexpr double kBias = 0.07;

// A ground robot's tag (0.3 m up) driving lanes over a 5 x 3.5 m floor, as the cameras see it.
std::vector<AnchorSample> lanes(double sigma, double nlos_fraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<AnchorSample> out;
  for (int lane = 0; lane < 8; ++lane)
    for (int k = 0; k < 50; ++k) {
      const Eigen::Vector3d tag(0.5 + 0.1 * k, 0.3 + 0.5 * lane, 0.3);
      double range = (tag - kTrue).norm() + kBias + sigma * noise(rng);
      if (u01(rng) < nlos_fraction) range += 0.3 + 0.5 * u01(rng);
      out.push_back({tag, range, std::max(sigma, 1e-4)});
    }
  return out;
}

TEST(AnchorCalibration, ExactRangesGiveTheMountedPositionAndTheBias) {
  const auto samples = lanes(0.0, 0.0, 1);
  const AnchorCalibration c = calibrate_anchor(kConfigured, samples);
  ASSERT_EQ(c.status, AnchorCalibration::Status::kOk) << anchor_calibration_status_word(c.status);
  EXPECT_LT((c.position - kTrue).norm(), 1e-6);
  EXPECT_NEAR(c.bias_m, kBias, 1e-6);
  EXPECT_EQ(c.samples, 400u);
  EXPECT_EQ(c.outliers, 0u);
  EXPECT_LT(c.rms_m, 1e-6);
}

TEST(AnchorCalibration, NoisyRangesAndReflectionsStayWithinTheStatedSigma) {
  // 2 cm ranges, 5 % of them 0.3-0.8 m long (a reflection).
  const auto samples = lanes(0.02, 0.05, 2);
  const AnchorCalibration c = calibrate_anchor(kConfigured, samples);
  ASSERT_EQ(c.status, AnchorCalibration::Status::kOk);
  std::printf(
      "2 cm ranges, 5 %% reflections: position off by %.1f mm (sigma %.1f %.1f %.1f mm), bias %.1f mm "
      "(truth 70, sigma %.1f), %zu outliers, rms %.1f mm\n",
      1e3 * (c.position - kTrue).norm(), 1e3 * c.sigma(0), 1e3 * c.sigma(1), 1e3 * c.sigma(2), 1e3 * c.bias_m,
      1e3 * c.sigma(3), c.outliers, 1e3 * c.rms_m);
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(c.position(k) - kTrue(k)), 3 * c.sigma(k) + 1e-3) << k;
  EXPECT_LT(std::abs(c.bias_m - kBias), 3 * c.sigma(3) + 1e-3);
  EXPECT_LT((c.position - kTrue).norm(), 0.03);
  EXPECT_GT(c.outliers, 12u);  // ~20 reflections
  EXPECT_LT(c.outliers, 30u);
  EXPECT_NEAR(c.rms_m, 0.02, 0.005);
  // What positioning needs: the range the calibrated anchor predicts anywhere on the floor.
  // Its height and bias are strongly correlated for tags in one plane (each ~1-2 cm alone),
  // their sum is not. Without the robust loss the reflections pull it long.
  AnchorCalibrationOptions plain;
  plain.robust_sigmas = 0;
  const AnchorCalibration p = calibrate_anchor(kConfigured, samples, plain);
  double worst = 0, worst_plain = 0, configured = 0;
  for (const AnchorSample& s : lanes(0.0, 0.0, 1)) {
    worst = std::max(worst, std::abs((s.tag - c.position).norm() + c.bias_m - s.range_m));
    worst_plain = std::max(worst_plain, std::abs((s.tag - p.position).norm() + p.bias_m - s.range_m));
    configured = std::max(configured, std::abs((s.tag - kConfigured).norm() - s.range_m));
  }
  std::printf(
      "predicted range over the floor, worst error: %.1f mm calibrated, %.1f mm without the robust loss, "
      "%.1f mm as configured\n",
      1e3 * worst, 1e3 * worst_plain, 1e3 * configured);
  EXPECT_LT(worst, 0.01);
  EXPECT_GT(worst_plain, 1.5 * worst);
  EXPECT_GT(configured, 0.1);
}

TEST(AnchorCalibration, ATagThatNeverMovedCannotPlaceTheAnchorButGivesItsBias) {
  std::vector<AnchorSample> still;
  const Eigen::Vector3d tag(2.0, 1.5, 0.3);
  for (int i = 0; i < 100; ++i) still.push_back({tag, (tag - kTrue).norm() + kBias, 0.01});
  EXPECT_EQ(calibrate_anchor(kConfigured, still).status, AnchorCalibration::Status::kPoorGeometry);
  // The bias alone, at the configured position: what the configured position's error makes it.
  AnchorCalibrationOptions bias_only;
  bias_only.unknowns = AnchorUnknowns::kBias;
  const AnchorCalibration b = calibrate_anchor(kConfigured, still, bias_only);
  ASSERT_EQ(b.status, AnchorCalibration::Status::kOk);
  EXPECT_EQ(b.position, kConfigured);
  EXPECT_NEAR(b.bias_m, (tag - kTrue).norm() + kBias - (tag - kConfigured).norm(), 1e-6);
  EXPECT_EQ(b.sigma.head<3>(), Eigen::Vector3d::Zero());
}

TEST(AnchorCalibration, TheBestItCanSayFallsBackToWhatTheGeometryDetermines) {
  // A tag on one circle (r 1.2 m, 0.3 m up) 3-6 m from the anchor: its ranges barely tell the
  // anchor's height from its bias, but do tell its horizontal position. (Configured at the
  // right height here, so that the horizontal estimate can be exact.)
  const Eigen::Vector3d configured(6.0, 0.0, kTrue.z());
  std::vector<AnchorSample> circle;
  for (int k = 0; k < 300; ++k) {
    const double a = 2 * M_PI * k / 300.0;
    const Eigen::Vector3d tag(3 + 1.2 * std::cos(a), 2 + 1.2 * std::sin(a), 0.3);
    circle.push_back({tag, (tag - kTrue).norm() + kBias, 0.02});
  }
  EXPECT_EQ(calibrate_anchor(configured, circle).status, AnchorCalibration::Status::kPoorGeometry);
  const AnchorCalibration h = calibrate_anchor_best(configured, circle);
  ASSERT_EQ(h.status, AnchorCalibration::Status::kOk);
  EXPECT_EQ(h.unknowns, AnchorUnknowns::kHorizontal);
  EXPECT_LT((h.position - kTrue).norm(), 1e-5);
  EXPECT_NEAR(h.bias_m, kBias, 1e-5);
  EXPECT_EQ(h.sigma(2), 0.0);
  EXPECT_GT(h.sigma(0), 0.0);
  // Lanes over the whole floor determine everything; a tag that never moved, the bias only.
  EXPECT_EQ(calibrate_anchor_best(kConfigured, lanes(0.0, 0.0, 5)).unknowns, AnchorUnknowns::kPosition);
  std::vector<AnchorSample> still(50, {Eigen::Vector3d(2.0, 1.5, 0.3), 2.0, 0.01});
  const AnchorCalibration b = calibrate_anchor_best(kConfigured, still);
  EXPECT_EQ(b.unknowns, AnchorUnknowns::kBias);
  EXPECT_EQ(b.status, AnchorCalibration::Status::kOk);
  EXPECT_STREQ(anchor_unknowns_word(b.unknowns), "bias");
}

TEST(AnchorCalibration, TooFewOrUnusableSamples) {
  auto samples = lanes(0.0, 0.0, 3);
  samples.resize(10);
  EXPECT_EQ(calibrate_anchor(kConfigured, samples).status, AnchorCalibration::Status::kTooFew);
  samples = lanes(0.0, 0.0, 3);
  samples[0].range_m = NAN;
  samples[1].sigma_m = 0;
  samples[2].tag.x() = INFINITY;
  const AnchorCalibration c = calibrate_anchor(kConfigured, samples);
  EXPECT_EQ(c.samples, 397u);
  EXPECT_EQ(c.status, AnchorCalibration::Status::kOk);
  EXPECT_STREQ(anchor_calibration_status_word(AnchorCalibration::Status::kPoorGeometry), "poor_geometry");
}

}  // namespace
}  // namespace ips
