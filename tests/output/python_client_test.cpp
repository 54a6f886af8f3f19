// The Python client (tools/ipsd_client.py) decodes what the C++ encoder writes.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/output/packet_codec.h"
#include "ips/output/wire.h"

namespace ips {
namespace {

std::string run(const std::string& command) {
  std::string out;
  FILE* p = ::popen(command.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  ::pclose(p);
  return out;
}

// What tools/ipsd_client.py prints for `bytes`: decode() as JSON, or the Malformed message
// (`malformed_message`).
std::string python_decode(const std::vector<std::uint8_t>& bytes, bool malformed_message = false) {
  const auto file = std::filesystem::temp_directory_path() / ("ips_py_" + std::to_string(::getpid()) + ".bin");
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  const std::string import =
      "import sys, json; sys.path.insert(0, '" IPS_SOURCE_DIR "/tools'); import ipsd_client as c";
  const std::string data = "open('" + file.string() + "', 'rb').read()";
  const std::string out = run("python3 -c \"" + import +
                              (malformed_message ? "\ntry: c.decode(" + data + ")\nexcept c.Malformed as e: print(e)\""
                                                 : "; print(json.dumps(c.decode(" + data + ")))\""));
  std::filesystem::remove(file);
  return out;
}

TEST(PythonClient, DecodesTheBinaryFormLikeTheCppDecoder) {
  if (std::system("python3 -c 'import struct' >/dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  Datagram d;
  d.has_velocity = true;
  d.sequence = 41;
  d.update = 7;
  d.capture_realtime_ns = 1'700'000'000'000'000'123;
  d.capture_monotonic_ns = 55;
  MarkerRecord m;
  m.id = 12;
  m.camera_mask = 6;
  m.x = 1.5;
  m.y = -0.25;
  m.z = 0.125;
  m.yaw = 0.5;
  m.quality = 800;
  m.dt_us = -1234;
  m.vx = 0.75;
  d.markers = {m};
  const auto j = nlohmann::json::parse(python_decode(encode_binary(d)));
  EXPECT_EQ(j["seq"], 41);
  EXPECT_EQ(j["update"], 7);
  EXPECT_EQ(j["t_capture_real_ns"], 1'700'000'000'000'000'123);
  EXPECT_EQ(j["velocity"], true);
  ASSERT_EQ(j["markers"].size(), 1u);
  EXPECT_EQ(j["markers"][0]["id"], 12);
  EXPECT_EQ(j["markers"][0]["cameras"], 6);
  EXPECT_DOUBLE_EQ(j["markers"][0]["x"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(j["markers"][0]["y"].get<double>(), -0.25);
  EXPECT_EQ(j["markers"][0]["dt_us"], -1234);
  EXPECT_DOUBLE_EQ(j["markers"][0]["vx"].get<double>(), 0.75);
}

TEST(PythonClient, ReadsWhatPlacedEachMarkerLikeTheJsonForm) {
  if (std::system("python3 -c 'import struct' >/dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  Datagram d;
  d.has_sources = true;
  MarkerRecord both, ranged;
  both.id = 3;
  both.camera_mask = 1;
  both.sources = IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES;
  ranged.id = 20;
  ranged.sources = IPS_WIRE_SOURCE_RANGES;
  ranged.has_yaw = false;
  d.markers = {both, ranged};
  const auto j = nlohmann::json::parse(python_decode(encode_binary(d)));
  const auto json_form = nlohmann::json::parse(encode_json(d));
  EXPECT_EQ(j["sources"], true);
  ASSERT_EQ(j["markers"].size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(j["markers"][i]["sources"], json_form["markers"][i]["sources"]) << i;
    EXPECT_EQ(j["markers"][i]["has_yaw"], json_form["markers"][i]["has_yaw"]) << i;
  }
  EXPECT_EQ(j["markers"][1]["sources"], nlohmann::json::array({"ranges"}));
  EXPECT_EQ(j["markers"][1]["has_yaw"], false);
}

TEST(PythonClient, DecodesVersion2Bodies) {
  if (std::system("python3 -c 'import struct' >/dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  Datagram d;
  d.version = 2;
  d.sequence = 3;
  MarkerRecord m;
  m.id = 4;
  m.x = 0.5;
  d.markers = {m};
  BodyRecord b;
  b.name = "tb3";
  b.camera_mask = 3;
  b.x = 1.25;
  b.y = -2.5;
  b.yaw = 0.75;
  b.qw = 0.5;
  b.qz = -0.5;
  b.has_yaw = true;
  b.dt_us = -40;
  b.id_count = 5;
  b.ids = {1, 2, 3, 9};
  b.has_velocity = true;
  b.vx = 0.25;
  b.vy = -0.5;
  b.vz = 0.125;
  d.bodies = {b, b};
  d.bodies[1].name = "still";
  d.bodies[1].has_velocity = false;  // no velocity measured yet: no keys
  d.bodies[1].has_yaw_rate = true;
  d.bodies[1].yaw_rate = -1.5;
  const auto bytes = encode_binary(d);
  const auto j = nlohmann::json::parse(python_decode(bytes));
  EXPECT_EQ(j["version"], 2);
  ASSERT_EQ(j["markers"].size(), 1u);
  EXPECT_DOUBLE_EQ(j["markers"][0]["x"].get<double>(), 0.5);
  ASSERT_EQ(j["bodies"].size(), 2u);
  const auto& jb = j["bodies"][0];
  EXPECT_EQ(jb["name"], "tb3");
  EXPECT_EQ(jb["cameras"], 3);
  EXPECT_DOUBLE_EQ(jb["x"].get<double>(), 1.25);
  EXPECT_DOUBLE_EQ(jb["y"].get<double>(), -2.5);
  EXPECT_DOUBLE_EQ(jb["yaw"].get<double>(), 0.75);
  EXPECT_DOUBLE_EQ(jb["qz"].get<double>(), -0.5);
  EXPECT_EQ(jb["has_yaw"], true);
  EXPECT_EQ(jb["dt_us"], -40);
  EXPECT_EQ(jb["id_count"], 5);
  EXPECT_EQ(jb["ids"], nlohmann::json({1, 2, 3, 9}));
  EXPECT_DOUBLE_EQ(jb["vx"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(jb["vy"].get<double>(), -0.5);
  EXPECT_DOUBLE_EQ(jb["vz"].get<double>(), 0.125);
  EXPECT_FALSE(jb.contains("yaw_rate"));
  const auto& still = j["bodies"][1];
  EXPECT_EQ(still["name"], "still");
  EXPECT_FALSE(still.contains("vx"));
  EXPECT_DOUBLE_EQ(still["yaw_rate"].get<double>(), -1.5);
  // The first senders' 100-byte body records: decoded, without velocity keys.
  const std::size_t section = 48 + 36 * d.markers.size();
  std::vector<std::uint8_t> first(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(section + 4));
  first[section + 2] = 100;
  for (std::size_t i = 0; i < d.bodies.size(); ++i) {
    const auto record = bytes.begin() + static_cast<std::ptrdiff_t>(section + 4 + 116 * i);
    first.insert(first.end(), record, record + 100);
  }
  const auto old = nlohmann::json::parse(python_decode(first));
  ASSERT_EQ(old["bodies"].size(), 2u);
  EXPECT_DOUBLE_EQ(old["bodies"][0]["x"].get<double>(), 1.25);
  EXPECT_FALSE(old["bodies"][0].contains("vx"));
  EXPECT_FALSE(old["bodies"][1].contains("yaw_rate"));
  // With sources (120-byte body records): a body placed by ranges alone says so.
  Datagram ranged = d;
  ranged.has_sources = true;
  ranged.markers[0].sources = IPS_WIRE_SOURCE_CAMERA;
  ranged.bodies[0].camera_mask = 0;
  ranged.bodies[0].has_yaw = false;
  ranged.bodies[0].sources = IPS_WIRE_SOURCE_RANGES;
  ranged.bodies[1].sources = IPS_WIRE_SOURCE_CAMERA | IPS_WIRE_SOURCE_RANGES;
  const auto with_sources = nlohmann::json::parse(python_decode(encode_binary(ranged)));
  ASSERT_EQ(with_sources["bodies"].size(), 2u);
  EXPECT_EQ(with_sources["bodies"][0]["sources"], nlohmann::json({"ranges"}));
  EXPECT_EQ(with_sources["bodies"][0]["has_yaw"], false);
  EXPECT_EQ(with_sources["bodies"][1]["sources"], nlohmann::json({"camera", "ranges"}));
  EXPECT_FALSE(old["bodies"][0].contains("sources"));
  // And a version it does not read: the clear refusal.
  auto v3 = bytes;
  v3[4] = 3;
  const std::string refused = python_decode(v3, /*malformed_message=*/true);
  EXPECT_EQ(refused, "ipsd stream version 3: this client reads versions 1 and 2; update it\n");
}

}  // namespace
}  // namespace ips
