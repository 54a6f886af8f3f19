// docs/survey.md tells other programs how to write a session's fingerprint byte for byte, with
// a Python function: that very function, run on two lenses, must give what ips computes.
#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "command.h"
#include "ips/survey/survey.h"

namespace {

std::string python_recipe() {
  std::ifstream in(std::string(IPS_CONFIG_DIR) + "/../docs/survey.md");
  std::stringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  const auto section = text.find("**The fingerprint, byte for byte**");
  const auto start = text.find("```python\n", section);
  const auto end = text.find("```", start + 10);
  if (section == std::string::npos || start == std::string::npos || end == std::string::npos) return "";
  return text.substr(start + 10, end - start - 10);
}

std::string python_list(const std::string& name, const ips::CameraModel& m) {
  std::ostringstream o;
  o.precision(17);
  o << "('" << name << "', " << m.size().width << ", " << m.size().height << ", [";
  for (int r = 0; r < 3; ++r) {
    o << "[";
    for (int c = 0; c < 3; ++c) o << m.K()(r, c) << (c < 2 ? ", " : "");
    o << "]" << (r < 2 ? ", " : "");
  }
  o << "], [";
  for (std::size_t i = 0; i < m.D().size(); ++i) o << m.D()[i] << (i + 1 < m.D().size() ? ", " : "");
  o << "])";
  return o.str();
}

TEST(FingerprintRecipe, TheDocumentedPythonGivesWhatIpsComputes) {
  const std::string recipe = python_recipe();
  ASSERT_FALSE(recipe.empty()) << "the recipe's python block is missing from docs/survey.md";
  const std::string data = IPS_TEST_DATA_DIR;
  const auto red = ips::CameraModel::load(data + "/ou2023/intrinsics_red.yaml");
  const auto white = ips::CameraModel::load(data + "/ou2023/intrinsics_white.yaml");
  const std::string expected = ips::survey::camera_fingerprint({{"up", red}, {"ceiling-2", white}});
  const std::string script = "/tmp/ips_fingerprint_recipe.py";
  std::ofstream(script) << recipe << "\nprint(fingerprint([" << python_list("up", red) << ", "
                        << python_list("ceiling-2", white) << "]))\n";
  const auto r = ips::test::run_shell("python3 " + script);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out, expected + "\n");
  std::remove(script.c_str());
}

}  // namespace
