// The calibration CSVs a person writes or edits: the pairs file ips fit reads
// (parse_calib_csv, also through `ips collect`'s PairsFile::parse when it resumes), the
// prepared world points of `ips collect --points`, and each line typed at `ips collect`'s
// prompt (parse_entry). All parse or fail with ips::InputError / false plus a message.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <string_view>

#include "fuzz_util.h"
#include "ips/collect/collect.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"

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
