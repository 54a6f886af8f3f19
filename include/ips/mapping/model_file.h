// The model file: one versioned JSON document holding every camera's fitted mapper.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "ips/mapping/mapper.h"

namespace ips {

struct CameraModelEntry {
  std::unique_ptr<Mapper> mapper;
  nlohmann::json training;  ///< summary of the data it was fitted on (n, ranges, cv table, ...)
};

/// Every camera's fitted model, keyed by camera name.
struct ModelSet {
  std::map<std::string, CameraModelEntry> cameras;

  /// The mapper for `camera`, or nullptr if the file has none.
  const Mapper* find(const std::string& camera) const;
};

/// Loads and validates a model file. Throws ips::InputError naming the file and the
/// problem (not JSON, wrong format tag, unsupported version, unknown method, bad parameters).
ModelSet load_model_file(const std::filesystem::path& path);

/// Writes atomically (temporary file + rename) so a reader never sees half a file.
void save_model_file(const ModelSet& models, const std::filesystem::path& path);

}  // namespace ips
