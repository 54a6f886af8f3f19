// outputs[i] of type ros2 in the configuration: defaults, ROS_DOMAIN_ID, marker names, and
// every bad value refused naming its key (the daemon's exit 2 is in ros2_ipsd_test.cpp).
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ips/config/config.h"
#include "ips/core/error.h"

namespace ips {
namespace {

const std::string kBase = R"(cameras:
  - {name: red, source: v4l2, device: /dev/video0, intrinsics: red.yaml}
model_file: model.json
markers:
  ids:
    3: {name: robot1}
    4: {height: 0.1}
)";

DaemonConfig parse(const std::string& outputs) {
  return parse_config(kBase + "outputs:\n" + outputs, "ipsd.yaml", ConfigChecks{false, false});
}

void expect_error(const std::string& outputs, const std::string& fragment) {
  try {
    (void)parse(outputs);
    ADD_FAILURE() << "accepted:\n" << outputs;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what() << "\n  missing: " << fragment;
  }
}

// Restores ROS_DOMAIN_ID at the end of a test.
struct DomainEnv {
  explicit DomainEnv(const char* value) {
    if (const char* v = std::getenv("ROS_DOMAIN_ID")) saved = v, had = true;
    if (value)
      ::setenv("ROS_DOMAIN_ID", value, 1);
    else
      ::unsetenv("ROS_DOMAIN_ID");
  }
  ~DomainEnv() {
    if (had)
      ::setenv("ROS_DOMAIN_ID", saved.c_str(), 1);
    else
      ::unsetenv("ROS_DOMAIN_ID");
  }
  std::string saved;
  bool had = false;
};

TEST(Ros2Config, DefaultsAndMarkerNames) {
  const DomainEnv env(nullptr);
  const DaemonConfig c = parse("  - {type: ros2}\n");
  ASSERT_EQ(c.outputs.size(), 1u);
  const OutputConfig& o = c.outputs[0];
  EXPECT_EQ(o.kind, OutputConfig::Kind::kRos2);
  EXPECT_EQ(o.ros2.domain, 0);
  EXPECT_EQ(o.ros2.prefix, "ipsd");
  EXPECT_EQ(o.ros2.frame_id, "world");
  EXPECT_EQ(o.ros2.child_frame_id, "{name}");
  EXPECT_TRUE(o.ros2.pose);
  EXPECT_TRUE(o.ros2.odometry);
  EXPECT_FALSE(o.ros2.tf);
  EXPECT_FALSE(o.ros2.reliable);
  EXPECT_EQ(o.ros2.depth, 5);
  ASSERT_EQ(o.ros2.marker_names.size(), 1u);  // only named markers; 4 becomes marker_4
  EXPECT_EQ(o.ros2.marker_names.at(3), "robot1");
  EXPECT_EQ(o.describe(), "ros2 domain 0 /ipsd");
}

TEST(Ros2Config, EveryKey) {
  const DomainEnv env("17");  // the key wins over the environment
  const DaemonConfig c = parse(
      "  - {type: ros2, domain: 42, prefix: /lab/ipsd, frame_id: map, child_frame_id: '{name}_base',\n"
      "     pose: false, odometry: true, tf: true, qos: reliable, depth: 20}\n");
  const Ros2OutputSettings& s = c.outputs[0].ros2;
  EXPECT_EQ(s.domain, 42);
  EXPECT_EQ(s.prefix, "lab/ipsd");  // a leading '/' is the same namespace
  EXPECT_EQ(s.frame_id, "map");
  EXPECT_EQ(s.child_frame_id, "{name}_base");
  EXPECT_FALSE(s.pose);
  EXPECT_TRUE(s.tf);
  EXPECT_TRUE(s.reliable);
  EXPECT_EQ(s.depth, 20);
}

TEST(Ros2Config, DomainFromRosDomainId) {
  {
    const DomainEnv env("17");
    EXPECT_EQ(parse("  - {type: ros2}\n").outputs[0].ros2.domain, 17);
  }
  const DomainEnv env("300");
  expect_error("  - {type: ros2}\n", "outputs[0].domain: not set, and ROS_DOMAIN_ID='300' is not 0..232");
}

TEST(Ros2Config, BadValuesNameTheirKey) {
  const DomainEnv env(nullptr);
  expect_error("  - {type: ros2, qos: fast}\n",
               "ipsd.yaml:9:23: outputs[0].qos: unknown value 'fast' (best_effort|reliable)");
  expect_error("  - {type: ros2, domain: 233}\n", "outputs[0].domain: must be 0..232");
  expect_error("  - {type: ros2, domain: -1}\n", "outputs[0].domain: must be 0..232");
  expect_error("  - {type: ros2, prefix: ''}\n", "outputs[0].prefix: empty");
  expect_error("  - {type: ros2, prefix: my-lab}\n", "outputs[0].prefix: 'my-lab' is not a ROS 2 namespace");
  expect_error("  - {type: ros2, depth: 0}\n", "outputs[0].depth: must be 1..1000");
  expect_error("  - {type: ros2, frame_id: /map}\n", "outputs[0].frame_id: a tf2 frame name must not start with '/'");
  expect_error("  - {type: ros2, child_frame_id: ''}\n", "outputs[0].child_frame_id: empty frame name");
  expect_error("  - {type: ros2, pose: false, odometry: false}\n", "nothing to publish");
  expect_error("  - {type: ros2, port: 5005}\n", "outputs[0].port: unknown key");
  expect_error("  - {type: ros3}\n", "outputs[0].type: unknown value 'ros3'");
}

TEST(Ros2Config, MarkerNamesMustBeRosNamesAndDistinct) {
  const DomainEnv env(nullptr);
  const std::string outputs = "outputs:\n  - {type: ros2}\n";
  const std::string head =
      "cameras:\n  - {name: red, source: v4l2, device: /dev/video0, intrinsics: red.yaml}\n"
      "model_file: model.json\n";
  try {
    (void)parse_config(head + "markers:\n  ids:\n    3: {name: robot 1}\n" + outputs, "ipsd.yaml", {false, false});
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find("ipsd.yaml:6:15: markers.ids.3.name: 'robot 1' is not usable in a ROS 2 topic name"),
        std::string::npos)
        << e.what();
  }
  EXPECT_THROW((void)parse_config(head + "markers:\n  ids:\n    3: {name: a}\n    5: {name: a}\n" + outputs,
                                  "ipsd.yaml", {false, false}),
               InputError);
  // Without a ros2 output any name is fine (ips listen shows it).
  EXPECT_NO_THROW((void)parse_config(head + "markers:\n  ids:\n    3: {name: robot 1}\n", "ipsd.yaml", {false, false}));
}

TEST(Ros2Config, BodyNamesMustBeRosNamesApartFromTheMarkers) {
  const DomainEnv env(nullptr);
  auto bodies = [](const std::string& name) {
    return "bodies:\n  - {name: " + name + ", cube: {id: 10, edge: 0.075, size: 0.10}}\n";
  };
  // kBase names marker 3 robot1; marker 4 is unnamed (ROS name marker_4).
  const std::string ros2 = "  - {type: ros2}\n";
  auto error_of = [&](const std::string& name) -> std::string {
    try {
      (void)parse_config(kBase + bodies(name) + "outputs:\n" + ros2, "ipsd.yaml", ConfigChecks{false, false});
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_of("cube_1"), "");
  EXPECT_NE(error_of("\"cube 1\"").find("ipsd.yaml: bodies[0].name: 'cube 1' is not usable in a ROS 2 topic name"),
            std::string::npos)
      << error_of("\"cube 1\"");
  EXPECT_NE(error_of("robot1").find("bodies[0].name: 'robot1' is also the name of marker 3"), std::string::npos)
      << error_of("robot1");
  EXPECT_NE(error_of("marker_4").find("bodies[0].name: 'marker_4' is the ROS 2 name of unnamed marker 4"),
            std::string::npos)
      << error_of("marker_4");
  EXPECT_EQ(error_of("marker_x"), "");
  // Without a ros2 output the stream's rule only (1-31 bytes of UTF-8).
  EXPECT_NO_THROW((void)parse_config(kBase + bodies("\"cube 1\""), "ipsd.yaml", ConfigChecks{false, false}));
}

TEST(Ros2Config, TheCommentedExampleOfTheShippedConfigLoads) {
  const DomainEnv env(nullptr);
  std::ifstream in(std::string(IPS_CONFIG_DIR) + "/ipsd.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string commented = "  # - {type: ros2";
  const auto at = yaml.find(commented);
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, commented.size(), "  - {type: ros2");
  const DaemonConfig c = parse_config(yaml, std::string(IPS_CONFIG_DIR) + "/ipsd.yaml", ConfigChecks{false, false});
  ASSERT_FALSE(c.outputs.empty());
  const OutputConfig& o = c.outputs.back();
  ASSERT_EQ(o.kind, OutputConfig::Kind::kRos2);
  EXPECT_EQ(o.ros2.marker_names.at(7), "arm_base");  // the example's marker names are ROS names
}

}  // namespace
}  // namespace ips
