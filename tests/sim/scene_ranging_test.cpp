// The scene's ranges (anchors:, nlos_zones:, tags:): exact distances by hand, the noise, bias,
// NLOS zones, dropouts and range limits they are drawn with, the errors a typo gets, and
// `ips sim ranges` through `ips trilaterate` against the exact truth.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "command.h"
#include "csv_rows.h"
#include "ips/core/error.h"
#include "ips/sim/scene.h"

namespace fs = std::filesystem;

namespace ips::sim {
namespace {

fs::path write_scene(const std::string& name, const std::string& text) {
  const fs::path d = fs::temp_directory_path() / ("ips_scene_ranging_" + name);
  fs::create_directories(d);
  std::ofstream(d / "scene.yaml") << text;
  return d / "scene.yaml";
}

// A tag 0.1 m above marker 1 at (3, 4, 0.1): z 0.2. Anchor 1 at (0, 0, 0.2) is exactly 5 m
// away, anchor 2 at (3, 4, 2.2) 2 m, anchor 3 at (3, 10, 8.2) sqrt(36 + 64) = 10 m.
const char* kScene = R"(markers:
  - {id: 1, x: 3, y: 4, height: 0.1}
  - {id: 2, x: 3, y: 1, height: 0.1}
anchors:
  - {id: 1, position: [0, 0, 0.2], sigma: 0}
  - {id: 2, position: [3, 4, 2.2], sigma: 0, bias: 0.03}
  - {id: 3, position: [3, 10, 8.2], sigma: 0, max_range: 9.5}
tags:
  - {id: 7, marker: 1, height: 0.1, range_tags: true, sigma: 0}
  - {id: 8, marker: 2, height: 0.1}
)";

TEST(SceneRanging, ExactDistancesPlusTheAnchorsBiasWithinItsRange) {
  const Scene s = Scene::load(write_scene("exact", kScene));
  ASSERT_EQ(s.anchors.size(), 3u);
  ASSERT_EQ(s.tags.size(), 2u);
  EXPECT_TRUE(s.cameras.empty());
  std::mt19937_64 rng(1);
  const auto r = s.fire_tag(0, 0.0, rng);
  ASSERT_EQ(r.size(), 3u);  // anchors 1 and 2 (3 is beyond its 9.5 m), then tag 8
  EXPECT_EQ(r[0].reference, 1);
  EXPECT_DOUBLE_EQ(r[0].range, 5.0);
  EXPECT_EQ(r[1].reference, 2);
  EXPECT_DOUBLE_EQ(r[1].true_range, 2.0);
  EXPECT_DOUBLE_EQ(r[1].range, 2.03);
  EXPECT_TRUE(r[2].is_tag);
  EXPECT_EQ(r[2].reference, 8);
  EXPECT_DOUBLE_EQ(r[2].range, 3.0);  // (3, 1, 0.2) from (3, 4, 0.2)
  EXPECT_EQ(r[2].reference_position, Eigen::Vector3d(3, 1, 0.2));
  // Tag 8 does not range to tags: anchors only (1 at sqrt(9 + 1) m, 2 at sqrt(9 + 4) m + 0.03).
  const auto r8 = s.fire_tag(1, 0.0, rng);
  ASSERT_EQ(r8.size(), 2u);  // anchor 3 is sqrt(81 + 64) = 12.04 m away, beyond 9.5
  EXPECT_NEAR(r8[0].range, std::sqrt(10.0), 1e-12);
  EXPECT_NEAR(r8[1].range, std::sqrt(13.0) + 0.03, 1e-12);
}

TEST(SceneRanging, NoiseNlosZonesAndDropoutsAreDrawnAsConfigured) {
  // Anchor 1's line to the tag passes through the box at x 1..2; anchor 2's does not.
  const Scene s = Scene::load(write_scene("stats", R"(markers:
  - {id: 1, x: 3, y: 4, height: 0.1}
anchors:
  - {id: 1, position: [0, 4, 0.2], sigma: 0.05}
  - {id: 2, position: [3, 0, 0.2], sigma: 0.02, dropout: 0.3}
nlos_zones:
  - {min: [1, 3.5, 0], max: [2, 4.5, 1], bias: 0.5}
tags:
  - {id: 7, marker: 1, height: 0.1}
)"));
  std::mt19937_64 rng(3);
  std::vector<double> e1, e2;
  const int n = 4000;
  for (int k = 0; k < n; ++k)
    for (const SimRange& r : s.fire_tag(0, 0.0, rng)) (r.reference == 1 ? e1 : e2).push_back(r.range - r.true_range);
  ASSERT_EQ(e1.size(), static_cast<std::size_t>(n));
  const auto mean = [](const std::vector<double>& v) {
    double m = 0;
    for (double x : v) m += x;
    return m / static_cast<double>(v.size());
  };
  const auto sd = [&](const std::vector<double>& v) {
    const double m = mean(v);
    double q = 0;
    for (double x : v) q += (x - m) * (x - m);
    return std::sqrt(q / static_cast<double>(v.size() - 1));
  };
  EXPECT_NEAR(mean(e1), 0.5, 0.005);  // the zone's bias; the noise's mean over 4000 is within 0.0025
  EXPECT_NEAR(sd(e1), 0.05, 0.0035);  // 5 standard errors of a standard deviation
  EXPECT_NEAR(mean(e2), 0.0, 0.002);
  EXPECT_NEAR(sd(e2), 0.02, 0.0016);
  EXPECT_NEAR(static_cast<double>(e2.size()) / n, 0.7, 0.04);  // dropout 0.3: binomial sd 0.007
}

TEST(SceneRanging, ATagsOdometryIsThePathItTravelled) {
  // Marker 1 on a circle of r 0.45 m at 0.2 m/s: the tag on it travels 0.2 m per second (an
  // arc, longer than its chord); a still tag travels nothing.
  const Scene s = Scene::load(write_scene("odometry", R"(markers:
  - {id: 1, height: 0.1, trajectory: {type: circle, center: [3, 2], radius: 0.45, speed: 0.2}}
  - {id: 2, x: 1, y: 1}
anchors:
  - {id: 1, position: [0, 0, 2.5]}
tags:
  - {id: 7, marker: 1, odometry: 0.002}
  - {id: 8, marker: 2}
)"));
  ASSERT_EQ(s.tags.size(), 2u);
  ASSERT_TRUE(s.tags[0].odometry);
  EXPECT_DOUBLE_EQ(*s.tags[0].odometry, 0.002);
  EXPECT_FALSE(s.tags[1].odometry);
  EXPECT_NEAR(s.tag_travelled(0, 1.0, 4.0), 0.6, 1e-6);
  const double chord = (*s.tag_position(0, 4.0) - *s.tag_position(0, 1.0)).norm();
  EXPECT_LT(chord, 0.59);
  EXPECT_EQ(s.tag_travelled(1, 0.0, 5.0), 0.0);
}

TEST(SceneRanging, TyposAreErrorsNamingTheLineAndKey) {
  const auto error_of = [](const std::string& name, const std::string& text) -> std::string {
    try {
      Scene::load(write_scene(name, text));
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  const std::string markers = "markers:\n  - {id: 1, x: 1, y: 1}\n";
  EXPECT_NE(error_of("e1", markers + "anchors:\n  - {id: 1, position: [0, 0]}\n").find(":4: anchors[0].position"),
            std::string::npos);
  EXPECT_NE(error_of("e2", markers + "anchors:\n  - {id: 1, position: [0, 0, 1], sigmaa: 1}\n")
                .find("anchors[0].sigmaa: unknown key"),
            std::string::npos);
  EXPECT_NE(error_of("e3", markers + "anchors:\n  - {id: 1, position: [0, 0, 1]}\ntags:\n  - {id: 7, marker: 2}\n")
                .find(":6: tags[0].marker: no marker 2"),
            std::string::npos);
  EXPECT_NE(error_of("e4", markers + "anchors:\n  - {id: 1, position: [0, 0, 1]}\n  - {id: 1, position: [1, 0, 1]}\n")
                .find("duplicate anchor id 1"),
            std::string::npos);
  EXPECT_NE(error_of("e5", markers + "anchors:\n  - {id: 1, position: [0, 0, 1]}\nnlos_zones:\n  - {min: [0, 0, 0], "
                                     "max: [1, 1, 1], bias: -1}\n")
                .find("nlos_zones[0].bias: must be > 0"),
            std::string::npos);
  EXPECT_NE(error_of("e6", markers).find("cameras"), std::string::npos);  // neither cameras nor anchors
  EXPECT_NE(error_of("e7", markers + "anchors:\n  - {id: 1, position: [0, 0, 1]}\ntags:\n  - {id: 7, marker: 1, "
                                     "odometry: 0}\n")
                .find(":6: tags[0].odometry: must be > 0"),
            std::string::npos);
}

// The Petkovic-like room of the issue: 4 anchors at the corners of a 6 x 4 m room at
// different heights, a beacon on a circle (r 0.45 m, 0.2 m/s) at 0.3 m, ranges with 2 cm noise;
// `ips sim ranges` -> `ips trilaterate` (robust) -> the fixes against the exact truth.
TEST(SceneRanging, SimRangesThroughTrilaterateMatchTheTruth) {
  const fs::path scene = write_scene("cli", R"(markers:
  - {id: 1, height: 0.1, trajectory: {type: circle, center: [3, 2], radius: 0.45, speed: 0.2}}
anchors:
  - {id: 1, position: [0, 0, 2.5], sigma: 0.02}
  - {id: 2, position: [6, 0, 1.0], sigma: 0.02}
  - {id: 3, position: [6, 4, 2.5], sigma: 0.02}
  - {id: 4, position: [0, 4, 0.4], sigma: 0.02}
  - {id: 5, position: [3, 0, 2.2], sigma: 0.02}
tags:
  - {id: 7, marker: 1, height: 0.2}
)");
  const fs::path dir = scene.parent_path();
  auto r =
      ips::test::run_program("ips", "sim ranges --scene " + scene.string() + " --out " + (dir / "ranges.csv").string() +
                                        " --truth " + (dir / "truth.csv").string() + " --anchors " +
                                        (dir / "anchors.yaml").string() + " --seconds 20 --rate 5");
  ASSERT_EQ(r.status, 0) << r.out;
  r = ips::test::run_program("ips", "trilaterate --anchors " + (dir / "anchors.yaml").string() + " --ranges " +
                                        (dir / "ranges.csv").string() + " --out " + (dir / "fixes.csv").string());
  ASSERT_EQ(r.status, 0) << r.out;
  const auto truth = ips::test::csv_rows(dir / "truth.csv"), fixes = ips::test::csv_rows(dir / "fixes.csv");
  ASSERT_EQ(truth.size(), 100u);
  ASSERT_EQ(fixes.size(), 100u);
  std::vector<double> errors;
  for (const auto& [name, t] : truth) {
    const auto& f = fixes.at(name);  // x y z cxx cxy cxz cyy cyz czz n status
    ASSERT_EQ(f[10], 1.0) << name;
    errors.push_back(std::hypot(f[0] - t[2], f[1] - t[3], f[2] - t[4]));
  }
  std::sort(errors.begin(), errors.end());
  std::printf(
      "[ sim     ] ips sim ranges -> ips trilaterate, 5 anchors, sigma 2 cm: 3-D error p50 %.1f p95 %.1f max %.1f mm\n",
      1e3 * errors[50], 1e3 * errors[95], 1e3 * errors.back());
  EXPECT_LT(errors[50], 0.05);
  EXPECT_LT(errors[95], 0.12);
}

// Ultrasound: ranges a module computed with 343 m/s in a 35 degC room, exact otherwise.
// `--temperature 35` scales them back (the fix within 1 mm of the truth); without it the fix
// is centimetres off.
TEST(SceneRanging, TrilaterateCorrectsUltrasoundRangesForTheTemperature) {
  const fs::path dir = fs::temp_directory_path() / ("ips_trilaterate_temperature_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const double anchors[4][3] = {{0, 0, 2.5}, {6, 0, 1.0}, {6, 4, 2.5}, {0, 4, 0.4}};
  const double truth[3] = {2.0, 1.5, 0.3};
  {
    std::ofstream a(dir / "anchors.yaml");
    a << "anchors:\n";
    for (int i = 0; i < 4; ++i)
      a << "  - {id: " << i + 1 << ", x: " << anchors[i][0] << ", y: " << anchors[i][1] << ", z: " << anchors[i][2]
        << "}\n";
    std::ofstream r(dir / "ranges.csv");
    r.precision(12);
    r << "fix,reference,range\n";
    const double c35 = 331.3 * std::sqrt(1.0 + 35.0 / 273.15);  // written out, not the library's
    for (int i = 0; i < 4; ++i)
      r << "f1," << i + 1 << ","
        << std::hypot(anchors[i][0] - truth[0], anchors[i][1] - truth[1], anchors[i][2] - truth[2]) * 343.0 / c35
        << "\n";
  }
  const auto fix_error = [&](const std::string& extra) {
    const auto r = ips::test::run_program("ips", "trilaterate --anchors " + (dir / "anchors.yaml").string() +
                                                     " --ranges " + (dir / "ranges.csv").string() + " --out " +
                                                     (dir / "fixes.csv").string() + " --method lsq" + extra);
    EXPECT_EQ(r.status, 0) << r.out;
    std::ifstream in(dir / "fixes.csv");
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    double x = 0, y = 0, z = 0;
    EXPECT_EQ(std::sscanf(row.c_str(), "f1,%lf,%lf,%lf", &x, &y, &z), 3) << row;
    return std::hypot(x - truth[0], y - truth[1], z - truth[2]);
  };
  EXPECT_GT(fix_error(""), 0.02);
  EXPECT_LT(fix_error(" --temperature 35 --assumed-speed 343"), 0.001);
  const auto bad = ips::test::run_program("ips", "trilaterate --anchors " + (dir / "anchors.yaml").string() +
                                                     " --ranges " + (dir / "ranges.csv").string() + " --out " +
                                                     (dir / "fixes.csv").string() + " --temperature 95");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("--temperature"), std::string::npos) << bad.out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips::sim
