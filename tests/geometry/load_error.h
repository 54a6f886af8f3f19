// The InputError message CameraModel::load gives for a file (a test failure if it loads).
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "ips/core/error.h"
#include "ips/geometry/camera_model.h"

namespace ips::test {

inline std::string camera_model_load_error(const std::filesystem::path& p) {
  try {
    ips::CameraModel::load(p);
  } catch (const ips::InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for " << p;
  return {};
}

}  // namespace ips::test
