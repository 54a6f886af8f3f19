// The `ranging:` section (docs/configuration.md, "Ranging"): what it reads, its defaults, and
// each mistake refused with the file, line and key.
#include "config_scratch.h"

namespace ips {
namespace {

class RangingConfig : public test::ConfigScratch {
 protected:
  static std::string with(const std::string& extra, const std::string& anchors = kThree,
                          const std::string& tags = "[{id: 7, marker: 20}]") {
    return test::kSyntheticRedConfig + "ranging:\n  port: 5800\n  anchors: " + anchors + "\n  tags: " + tags + "\n" +
           extra;
  }
  static constexpr const char* kThree =
      "[{id: 1, x: 0, y: 0, z: 2.5}, {id: 2, x: 4, y: 0, z: 1}, {id: 3, x: 4, y: 3, z: 2}]";
};

// A tag on a body: its body and its offset in the body's frame; a tag on a body's marker is
// refused with the way to say it (a body's marker is published inside its body only).
TEST_F(RangingConfig, TagsOnBodies) {
  const std::string bodies =
      "bodies:\n  - name: long\n"
      "    flat: [{id: 30, edge: 0.1, offset: [0.2, 0, 0.25]}, {id: 31, edge: 0.1, offset: [-0.2, 0, 0.25]}]\n";
  const auto c = parse_text(with(bodies, kThree, "[{id: 7, marker: 20}, {id: 9, body: long, offset: [0.1, 0, 0.3]}]"));
  const RangingTag& t = c.ranging.tags.at(9);
  EXPECT_TRUE(t.on_body());
  EXPECT_EQ(t.body, "long");
  EXPECT_EQ(t.offset, Eigen::Vector3d(0.1, 0, 0.3));
  EXPECT_FALSE(c.ranging.tags.at(7).on_body());
  EXPECT_EQ(c.ranging.input.tags, (std::set<std::uint32_t>{7, 9}));
  expect_refused(with(bodies, kThree, "[{id: 7, marker: 31}]"),
                 {"ranging.tags", "tag 7's marker 31 belongs to body 'long'", "body: long"});
}

TEST_F(RangingConfig, OffWithoutTheSectionAndItsDefaultsWithIt) {
  EXPECT_FALSE(parse_text(test::kSyntheticRedConfig).ranging.enabled());
  const auto c = parse_text(with("")).ranging;
  EXPECT_TRUE(c.enabled());
  EXPECT_EQ(c.input.port, 5800);
  EXPECT_EQ(c.input.address, "0.0.0.0");
  EXPECT_EQ(c.method, "robust");
  EXPECT_DOUBLE_EQ(c.sigma_m, 0.05);
  EXPECT_FALSE(c.height.has_value());
  ASSERT_EQ(c.anchors.size(), 3u);
  EXPECT_EQ(c.anchors.at(2).position, Eigen::Vector3d(4, 0, 1));
  EXPECT_DOUBLE_EQ(c.anchors.at(2).scale, 1.0);
  EXPECT_EQ(c.tags.at(7).marker, 20);
  // The input admits exactly the configured tags and anchors.
  EXPECT_EQ(c.input.tags, (std::set<std::uint32_t>{7}));
  EXPECT_EQ(c.input.anchors, (std::set<std::uint32_t>{1, 2, 3}));
  EXPECT_FALSE(c.temperature_c.has_value()) << "ranges are used as sent unless ultrasound: says otherwise";
  const auto u = parse_text(with("  ultrasound: {temperature: 28.5}\n")).ranging;
  EXPECT_DOUBLE_EQ(u.temperature_c.value(), 28.5);
  EXPECT_DOUBLE_EQ(u.assumed_speed_of_sound, 343.0);
  // Ranges go through a tracker per tag unless track: false.
  EXPECT_TRUE(c.track);
  EXPECT_EQ(c.track_options, RangeTrackerOptions{});
  EXPECT_FALSE(parse_text(with("  track: false\n")).ranging.track);
  const auto t = parse_text(with("  track: {process_noise: 2, gate: 0, learn_bias: false}\n")).ranging;
  EXPECT_TRUE(t.track);
  EXPECT_DOUBLE_EQ(t.track_options.process_noise, 2.0);
  EXPECT_DOUBLE_EQ(t.track_options.gate_sigmas, 0.0);
  EXPECT_EQ(t.track_options.bias_learning, RangeTrackerOptions::BiasLearning::kOff);
  EXPECT_EQ(parse_text(with("  track: {learn_bias: true}\n")).ranging.track_options.bias_learning,
            RangeTrackerOptions::BiasLearning::kOn);
  // A range between two tags updates both tracks unless track.mutual is false.
  EXPECT_TRUE(c.track_mutual);
  EXPECT_FALSE(parse_text(with("  track: {mutual: false}\n")).ranging.track_mutual);
}

TEST_F(RangingConfig, MistakesAreRefusedNamingTheKey) {
  expect_refused(with("  method: median5\n"), {"ipsd.yaml:", "ranging.method", "unknown value 'median5'", "median4"});
  expect_refused(with("  height: 0.1\n  z_range: [0, 2]\n"), {"ranging.z_range", "not both"});
  expect_refused(with("  z_range: [2, 0]\n"), {"ranging.z_range", "zmin <= zmax"});
  expect_refused(with("  allow: [10.0.0.1/8]\n"), {"ranging.allow[0]", "not an IPv4 subnet"});
  expect_refused(with("", "[{id: 1, x: 0, y: 0, z: 2}, {id: 1, x: 4, y: 0, z: 1}, {id: 3, x: 4, y: 3, z: 2}]"),
                 {"ranging.anchors[1].id", "listed twice"});
  expect_refused(with("", "[{id: 1, x: 0, y: 0, z: 2}, {id: 2, x: 4, y: 0, z: 1}]"),
                 {"ranging.anchors", "at least 3 anchors"});
  expect_refused(with("", "[{id: 1, x: 0, y: 0}, {id: 2, x: 4, y: 0, z: 1}, {id: 3, x: 4, y: 3, z: 2}]"),
                 {"ranging.anchors[0].z", "required"});
  expect_refused(with("", kThree, "[{id: -1, marker: 3}]"), {"ranging.tags[0].id", "0..2147483647"});
  expect_refused(with("", kThree, "[{id: 7}]"), {"ranging.tags[0]", "either `marker`", "or `body`"});
  expect_refused(with("", kThree, "[{id: 7, marker: 3, body: rover}]"), {"ranging.tags[0]", "either `marker`"});
  expect_refused(with("", kThree, "[{id: 7, marker: 3, offset: [0, 0, 0.1]}]"),
                 {"ranging.tags[0].offset", "on a body"});
  expect_refused(with("", kThree, "[{id: 7, body: rover, offset: [0, 0]}]"), {"ranging.tags[0].offset", "[x, y, z]"});
  expect_refused(with("", kThree, "[{id: 7, body: rover}]"), {"ranging.tags", "tag 7's body 'rover' is not in bodies"});
  expect_refused(with("", kThree, "[{id: 7, body: rover, height: 0.2}]"), {"ranging.tags[0].height", "`offset`"});
  expect_refused(with("", kThree, "[{id: 7, marker: 9}]") + "markers: {ids: {9: {fixed: [1, 2, 0]}}}\n",
                 {"ranging.tags", "fixed marker"});
  expect_refused(with("  prot: 5801\n"), {"ranging.prot", "unknown key"});
  expect_refused(with("  track: {process_noise: 0}\n"), {"ranging.track.process_noise"});
  expect_refused(with("  track: {gate: -1}\n"), {"ranging.track.gate"});
  expect_refused(with("  track: {learn_biases: true}\n"), {"ranging.track.learn_biases", "unknown key"});
  expect_refused(with("  track: maybe\n"), {"ranging.track"});
  expect_refused(with("  track: {learn_bias: often}\n"), {"ranging.track.learn_bias", "auto, true or false"});
  expect_refused(with("  ultrasound: {assumed_speed: 340}\n"), {"ranging.ultrasound.temperature", "required"});
  expect_refused(with("  ultrasound: {temperature: 95}\n"), {"ranging.ultrasound.temperature", "[-40, 60]"});
  expect_refused(with("  ultrasound: {temperature: 20, assumed_speed: 34.3}\n"),
                 {"ranging.ultrasound.assumed_speed", "[300, 400]"});
  expect_refused(test::kSyntheticRedConfig + "ranging: {anchors: " + kThree + ", tags: [{id: 7, marker: 20}]}\n",
                 {"ranging.port", "required"});
}

}  // namespace
}  // namespace ips
