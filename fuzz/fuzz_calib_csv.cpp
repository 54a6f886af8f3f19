// The calibration CSVs a person writes or edits: the pairs file ips fit reads
// (parse_calib_csv, also through `ips collect`'s PairsFile::parse when it resumes), the
// prepared world points of `ips collect --points`, and each line typed at `ips collect`'s
// prompt (parse_entry), and the ranges file of `ips trilaterate` (parse_ranges_csv, each fix
// then solved). All parse or fail with ips::InputError / false plus a message.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <string_view>

#include "fuzz_util.h"
#include "ips/collect/collect.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"
#include "ips/ranging/multilateration.h"
#include "ips/ranging/ranges_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(ips::fuzz::as_text(data, size));
  try {
    std::istringstream in(text);
    (void)ips::parse_calib_csv(in, "fuzz.csv");
  } catch (const ips::InputError&) {
  }
  try {
    (void)ips::collect::PairsFile::parse(text, "pairs.csv");
  } catch (const ips::InputError&) {
  }
  try {
    (void)ips::collect::parse_points_csv(text, "points.csv");
  } catch (const ips::InputError&) {
  }
  try {
    static const ips::AnchorMap anchors = {
        {"a", {0, 0, 2.5}}, {"b", {6, 0, 0.5}}, {"c", {6, 4, 2.5}}, {"1", {0, 4, 1}}};
    std::istringstream in(text);
    const auto fixes = ips::parse_ranges_csv(in, "ranges.csv", anchors);
    for (std::size_t i = 0; i < fixes.size() && i < 8; ++i) {
      if (fixes[i].ranges.size() > 20) continue;
      (void)ips::fix_least_squares(fixes[i].ranges);
      (void)ips::fix_from_subsets(fixes[i].ranges, ips::SubsetVote::kMedian);
    }
  } catch (const ips::InputError&) {
  }
  try {
    std::istringstream in(text);
    (void)ips::parse_positions_csv(in, "positions.csv");
  } catch (const ips::InputError&) {
  }
  std::string_view rest(text);
  for (int lines = 0; !rest.empty() && lines < 64; ++lines) {
    const std::size_t nl = rest.find('\n');
    const std::string_view line = rest.substr(0, nl);
    ips::collect::Entry entry;
    std::string error;
    (void)ips::collect::parse_entry(line, ips::collect::EntryLimits{}, entry, error);
    rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
  }
  return 0;
}
