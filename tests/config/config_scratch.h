// The fixture of the config tests: a scratch directory holding the files a daemon config may
// refer to (model.json, scene.yaml and red.yaml, the published red camera's intrinsics), so that
// relative paths in the text under test resolve against it. One directory per test, removed after.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>

#include <gtest/gtest.h>

#include "ips/config/config.h"
#include "ips/core/error.h"

namespace ips::test {

/// The smallest camera list the tests build on: one synthetic camera and the model file.
inline const std::string kSyntheticRedConfig =
    "cameras:\n  - {name: red, source: synthetic, scene: scene.yaml}\nmodel_file: model.json\n";

class ConfigScratch : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("ips_" + std::string(info->test_suite_name()) + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    std::filesystem::copy_file(std::filesystem::path(IPS_TEST_DATA_DIR) / "ou2023/intrinsics_red.yaml",
                               dir_ / "red.yaml", std::filesystem::copy_options::overwrite_existing);
    std::ofstream(dir_ / "model.json") << "{}";
    std::ofstream(dir_ / "scene.yaml") << "{}";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  /// The text parsed as the file `ipsd.yaml` of the scratch directory.
  DaemonConfig parse_text(const std::string& text, ConfigChecks checks = {}) const {
    return parse_config(text, dir_ / "ipsd.yaml", checks);
  }
  /// The InputError's message for the text, or "accepted".
  std::string error_of_text(const std::string& text, ConfigChecks checks = {}) const {
    try {
      (void)parse_text(text, checks);
    } catch (const InputError& e) {
      return e.what();
    }
    return "accepted";
  }
  /// Expects the text refused with an InputError whose message contains every fragment.
  void expect_refused(const std::string& text, std::initializer_list<std::string> fragments,
                      ConfigChecks checks = {}) const {
    const std::string error = error_of_text(text, checks);
    if (error == "accepted") {
      ADD_FAILURE() << "accepted:\n" << text;
      return;
    }
    for (const auto& f : fragments) EXPECT_NE(error.find(f), std::string::npos) << error << "\n  missing: " << f;
  }

  std::filesystem::path dir_;
};

}  // namespace ips::test
