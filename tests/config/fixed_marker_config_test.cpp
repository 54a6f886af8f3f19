// markers.ids.<id>.fixed / publish and fusion.fixed_marker_warn: values, defaults, and strict errors.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "config_scratch.h"
#include "ips/config/config.h"
#include "ips/core/error.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

class FixedMarkerConfigTest : public test::ConfigScratch {
 protected:
  DaemonConfig parse(const std::string& markers) { return parse_text(test::kSyntheticRedConfig + markers); }
  std::string error_of(const std::string& markers) { return error_of_text(test::kSyntheticRedConfig + markers); }
};

TEST_F(FixedMarkerConfigTest, FixedMarkersAreKnownHeightAndUnpublishedByDefault) {
  const DaemonConfig c = parse(
      "markers:\n  ids:\n    7: {fixed: [1.5, 2, 0.01]}\n    8: {fixed: [0, 0, 0], publish: true, height: 0.02}\n"
      "    9: {publish: false}\n    1: {height: 0.1}\n");
  ASSERT_TRUE(c.markers.ids.at(7).fixed);
  EXPECT_EQ(*c.markers.ids.at(7).fixed, (std::array<double, 3>{1.5, 2.0, 0.01}));
  EXPECT_DOUBLE_EQ(c.markers.height_of(7), 0.01);  // the surveyed z is its height
  EXPECT_DOUBLE_EQ(c.markers.height_of(8), 0.02);  // an explicit height wins
  EXPECT_FALSE(c.markers.published(7));
  EXPECT_TRUE(c.markers.published(8));
  EXPECT_FALSE(c.markers.published(9));
  EXPECT_TRUE(c.markers.published(1));
  EXPECT_TRUE(c.markers.published(42));  // unlisted ids are robots
  EXPECT_DOUBLE_EQ(c.fusion.fixed_marker_warn_m, 0.03);
  EXPECT_DOUBLE_EQ(parse("fusion: {fixed_marker_warn: 0.05}\n").fusion.fixed_marker_warn_m, 0.05);
}

TEST_F(FixedMarkerConfigTest, BadValuesNameTheKeyAndPlace) {
  const std::string want = "markers.ids.7.fixed: expected [x, y, z]: three finite numbers";
  for (const std::string bad :
       {"[1, 2]", "[1, 2, 3, 4]", "[1, two, 3]", "[1, 2, .nan]", "[1, 2, .inf]", "3", "{x: 1}", "[1, [2], 3]"}) {
    const std::string e = error_of("markers:\n  ids:\n    7: {fixed: " + bad + "}\n");
    EXPECT_NE(e.find("ipsd.yaml:6:"), std::string::npos) << bad << ": " << e;
    EXPECT_NE(e.find(want), std::string::npos) << bad << ": " << e;
  }
  EXPECT_NE(error_of("markers:\n  ids:\n    7: {fixed: [0, 0, 0], publish: maybe}\n")
                .find("markers.ids.7.publish: expected true or false"),
            std::string::npos);
  EXPECT_NE(error_of("fusion: {fixed_marker_warn: 0}\n").find("fusion.fixed_marker_warn: must be > 0"),
            std::string::npos);
  EXPECT_NE(error_of("markers:\n  ids:\n    7: {fixd: [0, 0, 0]}\n").find("markers.ids.7.fixd: unknown key"),
            std::string::npos);
}

}  // namespace
}  // namespace ips
