// `ips ranging calibrate` end to end against the simulator's truth: anchors put up a few to 20 cm
// off where the configuration says, modules reading up to 8 cm long; two tags (0.3 and 1.1 m up)
// on circles, their positions known at every firing (as the cameras would give them). The
// calibrated anchors file, through `ips trilaterate`, against the exact anchors and against
// the configured ones.
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

namespace fs = std::filesystem;

namespace ips::sim {
namespace {

TEST(RangingCalibrate, CalibratedAnchorsLocateAsWellAsTheExactOnes) {
  const fs::path dir = fs::temp_directory_path() / ("ips_ranging_calibrate_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "scene.yaml") << R"(markers:
  - {id: 1, height: 0.1, trajectory: {type: circle, center: [3, 2], radius: 1.5, speed: 0.3}}
  - {id: 2, height: 0.1, trajectory: {type: circle, center: [2, 1.8], radius: 0.8, speed: 0.2}}
anchors:
  - {id: 1, position: [0, 0, 2.5], sigma: 0.02, bias: 0.05}
  - {id: 2, position: [6, 0, 1.0], sigma: 0.02}
  - {id: 3, position: [6, 4, 2.5], sigma: 0.02, bias: -0.03}
  - {id: 4, position: [0, 4, 0.4], sigma: 0.02, bias: 0.08}
tags:
  - {id: 7, marker: 1, height: 0.2}
  - {id: 8, marker: 2, height: 1.0}
)";
  std::ofstream(dir / "configured.yaml") << R"(anchors:
  - {id: 1, x: 0.1, y: -0.05, z: 2.4}
  - {id: 2, x: 5.85, y: 0.1, z: 1.2}
  - {id: 3, x: 6, y: 4, z: 2.5}
  - {id: 4, x: 0, y: 4.15, z: 0.4}
)";
  const auto path = [&](const char* name) { return (dir / name).string(); };
  auto r = ips::test::run_program("ips", "sim ranges --scene " + path("scene.yaml") + " --out " + path("ranges.csv") +
                                             " --truth " + path("truth.csv") + " --anchors " + path("exact.yaml") +
                                             " --seconds 60 --rate 5 --seed 3");
  ASSERT_EQ(r.status, 0) << r.out;
  r = ips::test::run_program("ips", "ranging calibrate --anchors " + path("configured.yaml") + " --ranges " +
                                        path("ranges.csv") + " --positions " + path("truth.csv") + " --out " +
                                        path("calibrated.yaml"));
  ASSERT_EQ(r.status, 0) << r.out;
  std::printf("%s", r.out.c_str());
  EXPECT_NE(r.out.find("4 of 4 anchors calibrated"), std::string::npos) << r.out;

  const auto truth = ips::test::csv_rows(dir / "truth.csv");  // tag t x y z
  std::map<std::string, double> p95;
  for (const char* anchors : {"configured", "calibrated", "exact"}) {
    const std::string fixes = path(anchors) + "_fixes.csv";
    r = ips::test::run_program(
        "ips", "trilaterate --anchors " + path(anchors) + ".yaml --ranges " + path("ranges.csv") + " --out " + fixes);
    ASSERT_EQ(r.status, 0) << anchors << ": " << r.out;
    std::vector<double> errors;
    for (const auto& [name, f] : ips::test::csv_rows(fixes)) {  // x y z cxx cxy cxz cyy cyz czz n status
      ASSERT_EQ(f.size(), 11u) << name;
      const auto& t = truth.at(name);
      errors.push_back(std::hypot(f[0] - t[2], f[1] - t[3], f[2] - t[4]));
    }
    ASSERT_EQ(errors.size(), 600u) << anchors;
    std::sort(errors.begin(), errors.end());
    p95[anchors] = errors[static_cast<std::size_t>(0.95 * 599)];
    std::printf("[ ranging ] anchors %s: 3-D error p50 %.1f p95 %.1f mm\n", anchors, 1e3 * errors[300],
                1e3 * p95[anchors]);
  }
  EXPECT_LT(p95["calibrated"], 1.25 * p95["exact"]);
  EXPECT_LT(p95["calibrated"], 0.4 * p95["configured"]);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips::sim
