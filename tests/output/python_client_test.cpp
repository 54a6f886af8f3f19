// The Python client (tools/ipsd_client.py) decodes what the C++ encoder writes.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ips/packet_codec.h"

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
  const auto bytes = encode_binary(d);
  const auto file = std::filesystem::temp_directory_path() / ("ips_py_" + std::to_string(::getpid()) + ".bin");
  std::ofstream(file, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                              static_cast<std::streamsize>(bytes.size()));
  const std::string out = run("python3 -c \"import sys, json; sys.path.insert(0, '" IPS_SOURCE_DIR
                              "/tools'); import ipsd_client as c; print(json.dumps(c.decode(open('" +
                              file.string() + "', 'rb').read())))\"");
  std::filesystem::remove(file);
  const auto j = nlohmann::json::parse(out);
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

}  // namespace
}  // namespace ips
