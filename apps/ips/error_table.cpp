#include "error_table.h"

#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "ips/core/error.h"

namespace ips::cli {
namespace {

void print_cm(double metres) {
  if (std::isfinite(metres))
    std::printf(" %7.3f", metres * 100.0);
  else
    std::printf(" %7s", "-");
}

}  // namespace

void print_error_table(const std::string& label_header, const ErrorRows& rows) {
  std::printf("%-10s %4s | %-31s | %-31s\n", label_header.c_str(), "n", "3D error (cm)", "2D error (cm)");
  std::printf("%-10s %4s | %7s %7s %7s %7s | %7s %7s %7s %7s\n", "", "", "mean", "min", "max", "std", "mean", "min",
              "max", "std");
  for (const auto& [label, e] : rows) {
    std::printf("%-10s %4zu |", label.c_str(), e.n);
    for (double v : {e.err3d.mean, e.err3d.min, e.err3d.max, e.err3d.std}) print_cm(v);
    std::printf(" |");
    for (double v : {e.err2d.mean, e.err2d.min, e.err2d.max, e.err2d.std}) print_cm(v);
    std::printf("\n");
  }
}

void print_error_json(const ErrorRows& rows) {
  nlohmann::json cameras = nlohmann::json::object();
  for (const auto& [label, e] : rows) cameras[label] = errors_to_json(e);
  const nlohmann::json doc = {{"cameras", cameras}};
  std::printf("%s\n", doc.dump().c_str());
}

const CalibSet& require_camera(const CalibData& data, const std::string& camera) {
  const CalibSet* set = data.find(camera);
  if (set == nullptr)
    throw InputError(data.source + ": no pairs for camera '" + camera + "' (the file has: " + data.camera_list() + ")");
  return *set;
}

}  // namespace ips::cli
