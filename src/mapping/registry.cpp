// The mapper registry: every method by its fixed name.
#include <functional>
#include <utility>

#include "ips/core/error.h"
#include "ips/mapping/mapper.h"
#include "mapping/mappers.h"

namespace ips {
namespace {

using Factory = std::function<std::unique_ptr<Mapper>()>;

const std::vector<std::pair<std::string, Factory>>& factories() {
  using namespace ips::mapping;
  // The paper's table order, then the new methods.
  static const std::vector<std::pair<std::string, Factory>> list = {
      {"rt", make_rigid},
      {"pr", make_polynomial},
      {"rt+pr", [] { return make_chained(make_polynomial()); }},
      {"ann", make_ann},
      {"rt+ann", [] { return make_chained(make_ann()); }},
      {"ki", [] { return make_kriging(false); }},
      {"rt+ki", [] { return make_chained(make_kriging(false)); }},
      {"kr", [] { return make_kriging(true); }},
      {"rt+kr", [] { return make_chained(make_kriging(true)); }},
      {"plane", make_plane},
      {"auto", make_auto},
  };
  return list;
}

}  // namespace

std::unique_ptr<Mapper> make_mapper(const std::string& method) {
  for (const auto& [name, factory] : factories())
    if (name == method) return factory();
  std::string known;
  for (const auto& [name, factory] : factories()) known += (known.empty() ? "" : ", ") + name;
  throw InputError("unknown mapping method '" + method + "' (known: " + known + ")");
}

std::vector<std::string> mapper_names() {
  std::vector<std::string> names;
  for (const auto& entry : factories()) names.push_back(entry.first);
  return names;
}

std::string metric_name(ErrorMetric metric) { return metric == ErrorMetric::k2d ? "2d" : "3d"; }

ErrorMetric parse_metric(const std::string& text, const std::string& where) {
  if (text == "3d") return ErrorMetric::k3d;
  if (text == "2d") return ErrorMetric::k2d;
  throw InputError(where + ": unknown error metric '" + text + "' (use 3d or 2d)");
}

}  // namespace ips
