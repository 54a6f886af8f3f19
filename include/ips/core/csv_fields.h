// The comma-separated files ips reads (calibration pairs, placements, ranges) share one field
// syntax: fields split at every comma, blanks and a trailing CR trimmed, numbers in C syntax
// with an optional '+', finite only. Errors name the file:line and the column.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace ips {

/// `s` without leading blanks/tabs and trailing blanks/tabs/CR.
std::string_view trim_csv_field(std::string_view s);

/// The fields of one line, each trimmed (an empty line gives one empty field).
std::vector<std::string_view> split_csv_line(std::string_view line);

/// A finite number; throws InputError "<at>: <column>: '<text>' is not a number" (or "is out
/// of range", "is not a finite number", "empty value"). `column` is how the error names the
/// column, e.g. "column 'xc' (2)".
double parse_csv_number(std::string_view text, const std::string& at, const std::string& column);

}  // namespace ips
