// Model file: save -> load -> predict is bit-identical for every method; bad files are refused.
#include "ips/mapping/model_file.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "test_util.h"

namespace {

namespace fs = std::filesystem;

fs::path temp_path(const std::string& name) {
  return fs::temp_directory_path() / ("ips_mapping_test_" + std::to_string(::getpid()) + "_" + name);
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

std::string load_error(const std::string& text) {
  const fs::path p = temp_path("bad.json");
  write(p, text);
  try {
    ips::load_model_file(p);
  } catch (const ips::InputError& e) {
    fs::remove(p);
    return e.what();
  }
  fs::remove(p);
  return "no error";
}

class RoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(RoundTrip, SaveLoadPredictIsBitIdentical) {
  const auto data = ips::load_calib_csv(ips::test::train40_path());
  const ips::CalibSet& red = *data.find("red");
  // 24 pairs keep the nested cross-validation of `auto` quick (also under ASan).
  const std::vector<Eigen::Vector3d> cam(red.cam.begin(), red.cam.begin() + 24);
  const std::vector<Eigen::Vector3d> world(red.world.begin(), red.world.begin() + 24);
  ips::ModelSet set;
  ips::CameraModelEntry entry;
  entry.mapper = ips::make_mapper(GetParam());
  ips::FitOptions options;
  options.folds = 2;
  entry.mapper->fit(cam, world, options);
  entry.training = {{"n", 24}};
  set.cameras.emplace("red", std::move(entry));
  const fs::path p = temp_path("model_" + std::to_string(std::hash<std::string>{}(GetParam())) + ".json");
  ips::save_model_file(set, p);
  const ips::ModelSet loaded = ips::load_model_file(p);
  fs::remove(p);
  const ips::Mapper* m = loaded.find("red");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(loaded.find("white"), nullptr);
  EXPECT_EQ(m->method(), GetParam());
  EXPECT_EQ(loaded.cameras.at("red").training["n"], 24);
  const ips::Mapper* original = set.find("red");
  // Training points, all 40 (16 unseen), and points off the data.
  std::vector<Eigen::Vector3d> probes = red.cam;
  probes.emplace_back(0.0, 0.0, 2.0);
  probes.emplace_back(-1.234567891234, 0.98765432123, 2.1111111111);
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const double h = i < red.world.size() ? red.world[i].z() : 0.1;
    const Eigen::Vector3d a = original->predict(probes[i], h);
    const Eigen::Vector3d b = m->predict(probes[i], h);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a[k], b[k]) << GetParam() << " probe " << i;  // bitwise
  }
}

INSTANTIATE_TEST_SUITE_P(EveryMethod, RoundTrip, ::testing::ValuesIn(ips::mapper_names()),
                         [](const ::testing::TestParamInfo<std::string>& param_info) {
                           std::string s = param_info.param;
                           for (auto& ch : s)
                             if (ch == '+') ch = '_';
                           return s;
                         });

TEST(ModelFile, DoublesRoundTripExactly) {
  // nlohmann writes the shortest representation that reads back to the same double.
  for (double v : {0.1, 1.0 / 3.0, 2.220446049250313e-16, 123456789.123456789, -5e-324, 1.7976931348623157e308}) {
    const nlohmann::json j = {{"v", v}};
    EXPECT_EQ(nlohmann::json::parse(j.dump())["v"].get<double>(), v);
  }
}

const char* kGood = R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt","params":)"
                    R"({"R":[[1,0,0],[0,1,0],[0,0,1]],"t":[1,2,3]},"training":{}}}})";

TEST(ModelFile, AValidHandWrittenFileLoads) {
  const fs::path p = temp_path("good.json");
  write(p, kGood);
  const auto set = ips::load_model_file(p);
  fs::remove(p);
  EXPECT_EQ(set.find("red")->predict({1, 1, 1}), Eigen::Vector3d(2, 3, 4));
}

TEST(ModelFile, RefusesBadFilesWithClearErrors) {
  auto has = [](const std::string& msg, const std::string& part) { return msg.find(part) != std::string::npos; };
  std::string e = load_error("{\"format\": \"ipsd-model\", ");
  EXPECT_TRUE(has(e, "not a valid JSON document")) << e;
  // A number beyond double's range: nlohmann's out_of_range, not a parse_error (found by
  // fuzz_model_file, tests/fuzz/model_file/number_overflow.json).
  e = load_error(R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt","params":{"t":[1e999,0,0]}}}})");
  EXPECT_TRUE(has(e, "not a valid JSON document")) << e;
  e = load_error(R"({"format":"something-else","version":1,"cameras":{}})");
  EXPECT_TRUE(has(e, "not an ipsd model file")) << e;
  e = load_error(R"({"format":"ipsd-model","version":2,"cameras":{"a":{}}})");
  EXPECT_TRUE(has(e, "version 2 is not supported")) << e;
  e = load_error(R"({"format":"ipsd-model","version":1,"cameras":{}})");
  EXPECT_TRUE(has(e, "\"cameras\" must be a non-empty object")) << e;
  e = load_error(R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"magic","params":{}}}})");
  EXPECT_TRUE(has(e, "camera 'red': unknown mapping method 'magic'")) << e;
  e = load_error(
      R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt","params":{"R":[[1,0,0],[0,1,0],[0,0,1]]}}}})");
  EXPECT_TRUE(has(e, "camera 'red': parameter 't' is missing")) << e;
  e = load_error(
      R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt","params":{"R":[[1,0,0],[0,1,0],[0,0,1]],"t":[1,2]}}}})");
  EXPECT_TRUE(has(e, "parameter 't': expected an array of 3 numbers")) << e;
  e = load_error(
      R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt","params":{"R":[[1,0,0],[0,1,0],[0,0,1]],"t":[1,null,2]}}}})");
  EXPECT_TRUE(has(e, "parameter 't[1]': expected a number")) << e;
  e = load_error(
      R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt","params":{"R":[[2,0,0],[0,1,0],[0,0,1]],"t":[1,2,3]}}}})");
  EXPECT_TRUE(has(e, "parameter 'R': not a rotation matrix")) << e;
  e = load_error(
      R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"pr","params":{"terms":"1,x,y,z,xy,xz,yz,x2,y2,z2","coefficients":[[1,2,3]]}}}})");
  EXPECT_TRUE(has(e, "parameter 'coefficients'")) << e;
  e = load_error(
      R"({"format":"ipsd-model","version":1,"cameras":{"red":{"method":"rt+ki","params":{"rt":{"R":[[1,0,0],[0,1,0],[0,0,1]],"t":[0,0,0]}}}}})");
  EXPECT_TRUE(has(e, "parameter 'inner' is missing")) << e;
  // A truncated copy of a valid file.
  e = load_error(std::string(kGood).substr(0, 60));
  EXPECT_TRUE(has(e, "not a valid JSON document")) << e;
  try {
    ips::load_model_file("/nonexistent/model.json");
    FAIL();
  } catch (const ips::InputError& err) {
    EXPECT_TRUE(has(err.what(), "/nonexistent/model.json: cannot open")) << err.what();
  }
}

}  // namespace
