// The model file: {"format": "ipsd-model", "version": 1, "generator": ...,
//                  "cameras": {"<name>": {"method", "params", "training"}}}.
#include "ips/mapping/model_file.h"

#include <unistd.h>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "ips/core/error.h"

namespace ips {
namespace {

constexpr const char* kFormat = "ipsd-model";
constexpr int kVersion = 1;

}  // namespace

const Mapper* ModelSet::find(const std::string& camera) const {
  const auto it = cameras.find(camera);
  return it == cameras.end() ? nullptr : it->second.mapper.get();
}

ModelSet load_model_file(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(name + ": cannot open model file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(buffer.str());
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(name + ": not a valid JSON document (byte " + std::to_string(e.byte) + ")");
  } catch (const nlohmann::json::exception& e) {
    // A number beyond double's range is an out_of_range error, not a parse_error (found by
    // fuzz_model_file).
    throw InputError(name + ": not a valid JSON document (" + e.what() + ")");
  }
  if (!doc.is_object() || !doc.contains("format") || doc["format"] != kFormat)
    throw InputError(name + ": not an ipsd model file (missing \"format\": \"" + kFormat + "\")");
  if (!doc.contains("version") || !doc["version"].is_number_integer())
    throw InputError(name + ": model file has no integer \"version\"");
  if (doc["version"].get<long long>() != kVersion)
    throw InputError(name + ": model file version " + doc["version"].dump() +
                     " is not supported (this build reads version " + std::to_string(kVersion) + ")");
  if (!doc.contains("cameras") || !doc["cameras"].is_object() || doc["cameras"].empty())
    throw InputError(name + ": \"cameras\" must be a non-empty object");

  ModelSet set;
  for (const auto& [camera, entry] : doc["cameras"].items()) {
    const std::string at = name + ": camera '" + camera + "'";
    if (!entry.is_object()) throw InputError(at + ": expected an object");
    if (!entry.contains("method") || !entry["method"].is_string()) throw InputError(at + ": missing \"method\"");
    if (!entry.contains("params") || !entry["params"].is_object()) throw InputError(at + ": missing \"params\" object");
    CameraModelEntry model;
    try {
      model.mapper = make_mapper(entry["method"].get<std::string>());
      model.mapper->from_json(entry["params"]);
    } catch (const InputError& e) {
      throw InputError(at + ": " + e.what());
    } catch (const nlohmann::json::exception& e) {
      throw InputError(at + ": malformed parameters (" + e.what() + ")");
    }
    model.training = entry.value("training", nlohmann::json::object());
    set.cameras.emplace(camera, std::move(model));
  }
  return set;
}

void save_model_file(const ModelSet& models, const std::filesystem::path& path) {
  nlohmann::json doc;
  doc["format"] = kFormat;
  doc["version"] = kVersion;
  doc["generator"] = std::string("ips ") + IPS_VERSION;
  doc["cameras"] = nlohmann::json::object();
  for (const auto& [camera, entry] : models.cameras) {
    if (!entry.mapper) throw std::invalid_argument("save_model_file: camera without a mapper");
    doc["cameras"][camera] = {
        {"method", entry.mapper->method()}, {"params", entry.mapper->to_json()}, {"training", entry.training}};
  }
  const std::string text = doc.dump(1) + "\n";

  const std::filesystem::path tmp = path.string() + ".tmp." + std::to_string(static_cast<long long>(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path.string() + ": cannot write (" + tmp.string() + ")");
    out << text;
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw InputError(path.string() + ": write failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw InputError(path.string() + ": cannot replace the file (" + ec.message() + ")");
  }
}

}  // namespace ips
