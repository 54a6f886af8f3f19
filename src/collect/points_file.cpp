// The list of placements prepared in advance for `ips collect --points`.
#include <sstream>

#include "ips/collect/collect.h"
#include "ips/core/csv_fields.h"
#include "ips/core/error.h"

namespace ips::collect {
std::vector<Eigen::Vector3d> parse_points_csv(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string line;
  std::size_t line_no = 0;
  std::vector<std::string_view> header;
  std::string header_line;
  while (header.empty() && std::getline(in, header_line)) {
    ++line_no;
    if (!trim_csv_field(header_line).empty()) header = split_csv_line(header_line);
  }
  if (header.empty()) throw InputError(name + ": empty file (expected a header line 'xw,yw,zw')");
  const std::size_t header_no = line_no;
  int col[3] = {-1, -1, -1};
  const char* names[3] = {"xw", "yw", "zw"};
  for (std::size_t i = 0; i < header.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (header[i] == names[k]) col[k] = static_cast<int>(i);
  for (int k = 0; k < 3; ++k)
    if (col[k] < 0)
      throw InputError(name + ":" + std::to_string(header_no) + ": missing column '" + names[k] +
                       "' (header must name xw,yw,zw)");
  std::vector<Eigen::Vector3d> points;
  while (std::getline(in, line)) {
    ++line_no;
    if (trim_csv_field(line).empty()) continue;
    const auto fields = split_csv_line(line);
    const std::string at = name + ":" + std::to_string(line_no);
    if (fields.size() != header.size())
      throw InputError(at + ": " + std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(header.size()));
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k)
      p[k] = parse_csv_number(fields[static_cast<std::size_t>(col[k])], at, std::string("column '") + names[k] + "'");
    points.push_back(p);
  }
  if (points.empty()) throw InputError(name + ": no positions after the header");
  return points;
}

}  // namespace ips::collect
