// bodies: in the daemon's config: values, and bad definitions refused naming the key and place.
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

class BodiesConfigTest : public test::ConfigScratch {
 protected:
  DaemonConfig parse(const std::string& extra) { return parse_text(test::kSyntheticRedConfig + extra); }
  std::string error_of(const std::string& extra) { return error_of_text(test::kSyntheticRedConfig + extra); }
};

TEST_F(BodiesConfigTest, CubeAndFlatHelpers) {
  const DaemonConfig c = parse(
      "bodies:\n"
      "  - name: turtle\n"
      "    cube: {id: 5, edge: 0.075, size: 0.10, height: 0.30}\n"
      "  - name: long\n"
      "    flat: [{id: 7, edge: 0.1, offset: [0.2, 0, 0.25]}, {id: 8, edge: 0.1, offset: [-0.2, 0, 0.25]}]\n");
  ASSERT_EQ(c.bodies.size(), 2u);
  EXPECT_EQ(c.bodies[0].name, "turtle");
  EXPECT_EQ(c.bodies[0].markers.size(), 5u);
  EXPECT_DOUBLE_EQ(c.bodies[1].markers[1].position.x(), -0.2);
  EXPECT_TRUE(parse("").bodies.empty());
}

TEST_F(BodiesConfigTest, BadBodiesNameTheKeyAndLine) {
  // The three of the issue: a zero-size cube, an id in two bodies, overlapping faces.
  EXPECT_NE(error_of("bodies:\n  - {name: a, cube: {id: 1, edge: 0.05, size: 0}}\n")
                .find("ipsd.yaml:5:47: bodies[0].cube.size: must be > 0"),
            std::string::npos)
      << error_of("bodies:\n  - {name: a, cube: {id: 1, edge: 0.05, size: 0}}\n");
  const std::string two = error_of(
      "bodies:\n  - {name: a, cube: {id: 1, edge: 0.05, size: 0.1}}\n  - {name: b, flat: [{id: 1, edge: 0.1, offset: "
      "[0, 0]}]}\n");
  EXPECT_NE(two.find("ipsd.yaml:6:5: bodies[1]: marker id 1 is already used by body 'a' (bodies[0])"),
            std::string::npos)
      << two;
  const std::string overlap = error_of(
      "bodies:\n  - name: a\n    markers:\n      - {id: 2, edge: 0.1, position: [0, 0, 0.2]}\n"
      "      - {id: 3, edge: 0.1, position: [0.05, 0.05, 0.2]}\n");
  EXPECT_NE(
      overlap.find("ipsd.yaml:8:9: bodies[0].markers[1]: overlapping faces in one plane with bodies[0].markers[0]"),
      std::string::npos)
      << overlap;
  EXPECT_NE(error_of("bodies:\n  - {name: a, cube: {id: 100, edge: 0.05, size: 0.1}}\n")
                .find("marker id 100 is not in DICT_4X4_100"),
            std::string::npos);
  EXPECT_NE(
      error_of(
          "markers:\n  ids:\n    4: {fixed: [1, 1, 0]}\nbodies:\n  - {name: a, cube: {id: 4, edge: 0.05, size: 0.1}}\n")
          .find("marker id 4 is a fixed marker"),
      std::string::npos);
  EXPECT_NE(error_of("bodies: {name: a}\n").find("bodies: expected a non-empty list"), std::string::npos);
  EXPECT_NE(error_of("bodies:\n  - {name: a, cube: {id: 1, edge: 0.05, size: 0.1, colour: red}}\n")
                .find("bodies[0].cube.colour: unknown key"),
            std::string::npos);
}

}  // namespace
}  // namespace ips
