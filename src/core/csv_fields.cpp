#include "ips/core/csv_fields.h"

#include <charconv>
#include <cmath>

#include "ips/core/error.h"

namespace ips {

std::string_view trim_csv_field(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_csv_line(std::string_view line) {
  std::vector<std::string_view> fields;
  while (true) {
    const std::size_t comma = line.find(',');
    fields.push_back(trim_csv_field(line.substr(0, comma)));
    if (comma == std::string_view::npos) return fields;
    line.remove_prefix(comma + 1);
  }
}

double parse_csv_number(std::string_view text, const std::string& at, const std::string& column) {
  if (text.empty()) throw InputError(at + ": " + column + ": empty value");
  std::string_view digits = text;
  if (digits.front() == '+') digits.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range)
    throw InputError(at + ": " + column + ": value '" + std::string(text) + "' is out of range");
  if (ec != std::errc() || end != digits.data() + digits.size())
    throw InputError(at + ": " + column + ": '" + std::string(text) + "' is not a number");
  if (!std::isfinite(value))
    throw InputError(at + ": " + column + ": '" + std::string(text) + "' is not a finite number");
  return value;
}

}  // namespace ips
