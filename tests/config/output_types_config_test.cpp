// outputs[i] of types mavlink and subscriptions: every key read, defaults, and each bad value
// refused naming its key.
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

class MavlinkConfigTest : public test::ConfigScratch {
 protected:
  DaemonConfig parse(const std::string& outputs) { return parse_text(base_ + outputs, ConfigChecks{false, true}); }
  void expect_error(const std::string& outputs, const std::string& fragment) {
    expect_refused(base_ + outputs, {fragment}, ConfigChecks{false, true});
  }

  std::string base_ = test::kSyntheticRedConfig + "fusion: {kalman: {reset_after: 0.8}}\noutputs:\n";
};

TEST_F(MavlinkConfigTest, EveryKeyIsReadAndDefaultsAreTheDocumentedOnes) {
  DaemonConfig c = parse(R"(  - type: mavlink
    address: 192.168.1.50
    port: 14540
    vehicles:
      - {marker: 3, system_id: 1}
      - {marker: 7, system_id: 2, address: 192.168.1.51, port: 14541, marker_yaw_deg: 90}
    messages: [odometry]
    component_id: 191
    rate_limit: 40
    yaw_offset_deg: -12.5
    track_gap: 0.25
    yaw_stddev_deg: 3
    heartbeat: false
  - {type: mavlink, address: 127.0.0.1, port: 14550, vehicles: [{marker: 1, system_id: 255}]}
)");
  ASSERT_EQ(c.outputs.size(), 2u);
  const MavlinkOutputSettings& m = c.outputs[0].mavlink;
  EXPECT_EQ(c.outputs[0].kind, OutputConfig::Kind::kMavlink);
  EXPECT_EQ(c.outputs[0].address, "192.168.1.50");
  EXPECT_EQ(c.outputs[0].port, 14540);
  ASSERT_EQ(m.vehicles.size(), 2u);
  EXPECT_EQ(m.vehicles[0], (MavlinkVehicle{3, 1, "", 0, 0.0}));
  EXPECT_EQ(m.vehicles[1], (MavlinkVehicle{7, 2, "192.168.1.51", 14541, 90.0}));
  EXPECT_FALSE(m.vision_position_estimate);
  EXPECT_TRUE(m.odometry);
  EXPECT_EQ(m.component_id, 191);
  EXPECT_EQ(m.rate_limit_hz, 40);
  EXPECT_EQ(m.yaw_offset_deg, -12.5);
  EXPECT_EQ(m.track_gap_s, 0.25);
  EXPECT_EQ(m.yaw_stddev_deg, 3);
  EXPECT_FALSE(m.heartbeat);
  EXPECT_EQ(c.outputs[0].describe(), "mavlink 192.168.1.50:14540 (2 vehicle(s))");

  const MavlinkOutputSettings& d = c.outputs[1].mavlink;
  EXPECT_TRUE(d.vision_position_estimate);
  EXPECT_FALSE(d.odometry);
  EXPECT_EQ(d.component_id, 197);  // MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
  EXPECT_EQ(d.rate_limit_hz, 30);
  EXPECT_EQ(d.yaw_offset_deg, 0);
  EXPECT_EQ(d.track_gap_s, 0.8);  // = fusion.kalman.reset_after
  EXPECT_TRUE(d.heartbeat);
}

TEST_F(MavlinkConfigTest, BadValuesNameTheirKey) {
  const std::string head = "  - {type: mavlink, address: 127.0.0.1, port: 14550, ";
  expect_error(head + "vehicles: [{marker: 1, system_id: 0}]}\n", "outputs[0].vehicles[0].system_id: must be 1..255");
  expect_error(head + "vehicles: [{marker: 1, system_id: 256}]}\n", "outputs[0].vehicles[0].system_id: must be 1..255");
  expect_error(head + "vehicles: [{marker: 1, system_id: one}]}\n",
               "outputs[0].vehicles[0].system_id: expected an integer");
  expect_error(head + "vehicles: [{marker: 1}]}\n", "outputs[0].vehicles[0].system_id: required key is missing");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2}, {marker: 4, system_id: 2}]}\n",
               "outputs[0].vehicles[1].system_id: system id 2 is already a vehicle");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2}, {marker: 1, system_id: 3}]}\n",
               "outputs[0].vehicles[1].marker: marker 1 is already a vehicle");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2, sysid: 3}]}\n",
               "outputs[0].vehicles[0].sysid: unknown key");
  expect_error(head + "vehicles: []}\n", "outputs[0].vehicles: expected a non-empty list");
  expect_error("  - {type: mavlink, address: 127.0.0.1, port: 14550}\n",
               "outputs[0].vehicles: required key is missing");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2}], messages: [attitude]}\n",
               "outputs[0].messages: unknown message 'attitude'");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2}], component_id: 0}\n",
               "outputs[0].component_id: must be 1..255");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2}], rate_limit: 0}\n", "outputs[0].rate_limit: must be > 0");
  expect_error(head + "vehicles: [{marker: 1, system_id: 2}], format: json}\n", "outputs[0].format: unknown key");
  expect_error("  - {type: mavlnk, address: 127.0.0.1, port: 14550}\n", "outputs[0].type: unknown value 'mavlnk'");
}

TEST_F(MavlinkConfigTest, SubscriptionsKeysDefaultsAndBadValues) {
  DaemonConfig c = parse(R"(  - type: subscriptions
    port: 5010
    allow: [10.0.0.0/8, 192.168.1.7]
    psk: "lab key"
    max_subscribers: 4
    max_lease: 120
  - {type: subscriptions, address: 127.0.0.1, port: 5011}
)");
  ASSERT_EQ(c.outputs.size(), 2u);
  EXPECT_EQ(c.outputs[0].kind, OutputConfig::Kind::kSubscriptions);
  EXPECT_EQ(c.outputs[0].address, "0.0.0.0");
  EXPECT_EQ(c.outputs[0].port, 5010);
  EXPECT_EQ(c.outputs[0].subscriptions.allow, (std::vector<std::string>{"10.0.0.0/8", "192.168.1.7"}));
  EXPECT_EQ(c.outputs[0].subscriptions.psk, "lab key");
  EXPECT_EQ(c.outputs[0].subscriptions.max_subscribers, 4);
  EXPECT_EQ(c.outputs[0].subscriptions.max_lease_s, 120);
  EXPECT_EQ(c.outputs[0].describe(), "subscriptions on 0.0.0.0:5010");
  const SubscriptionSettings defaults;
  EXPECT_EQ(c.outputs[1].subscriptions, defaults);
  EXPECT_EQ(defaults.allow, (std::vector<std::string>{"0.0.0.0/0"}));
  EXPECT_EQ(defaults.max_subscribers, 16);
  EXPECT_EQ(defaults.max_lease_s, 60);

  expect_error("  - {type: subscriptions, port: 5010, allow: [10.0.0.0/8, 10.1.0.0/33]}\n",
               "outputs[0].allow[1]: '10.1.0.0/33' is not an IPv4 subnet");
  expect_error("  - {type: subscriptions, port: 5010, allow: [lab-wifi]}\n",
               "outputs[0].allow[0]: 'lab-wifi' is not an IPv4 subnet");
  expect_error("  - {type: subscriptions, port: 5010, allow: [10.0.0.1/8]}\n", "outputs[0].allow[0]:");
  expect_error("  - {type: subscriptions, port: 5010, allow: []}\n", "outputs[0].allow: expected a non-empty list");
  expect_error("  - {type: subscriptions, port: 5010, max_subscribers: 0}\n",
               "outputs[0].max_subscribers: must be 1..1024");
  expect_error("  - {type: subscriptions, port: 5010, max_lease: 0.5}\n", "outputs[0].max_lease: must be >= 1");
  expect_error("  - {type: subscriptions}\n", "outputs[0].port: required key is missing");
  expect_error("  - {type: subscriptions, port: 5010, format: json}\n", "outputs[0].format: unknown key");
}

// The outputs of the shipped config/ipsd.yaml, with its commented-out mavlink block enabled,
// parse (the file's cameras need devices and intrinsics that are not here, so the whole file
// cannot be loaded in a test).
TEST_F(MavlinkConfigTest, ShippedExampleOutputsParseWithTheMavlinkBlockEnabled) {
  std::ifstream in(std::string(IPS_CONFIG_DIR) + "/ipsd.yaml");
  std::string line, outputs;
  bool inside = false, block = false;
  while (std::getline(in, line)) {
    if (line == "outputs:") {
      inside = true;
      continue;
    }
    if (!inside) continue;
    if (!line.empty() && line[0] != ' ') break;  // the next top-level key
    if (line.rfind("  # - type: mavlink", 0) == 0) block = true;
    if (block && line.rfind("  #", 0) != 0) block = false;
    if (block) line.erase(2, 2);  // "  # - type" -> "  - type", "  #   port" -> "    port"
    outputs += line + "\n";
  }
  const DaemonConfig c = parse(outputs);
  ASSERT_EQ(c.outputs.size(), 5u);
  EXPECT_EQ(c.outputs[3].kind, OutputConfig::Kind::kSubscriptions);
  EXPECT_EQ(c.outputs[3].subscriptions.allow, (std::vector<std::string>{"192.168.1.0/24"}));
  EXPECT_EQ(c.outputs[4].kind, OutputConfig::Kind::kMavlink);
  EXPECT_EQ(c.outputs[4].mavlink.vehicles.size(), 2u);
  EXPECT_EQ(c.outputs[4].mavlink.vehicles[1].address, "192.168.1.32");
}

}  // namespace
}  // namespace ips
