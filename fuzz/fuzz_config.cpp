// The daemon's configuration (ipsd.yaml, also re-read on SIGHUP): any text parses into a
// DaemonConfig or fails with ips::InputError. File existence checks are off (the paths a
// fuzzed config names do not exist); everything else parse_config checks runs.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_util.h"
#include "ips/config/config.h"
#include "ips/core/error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(ips::fuzz::as_text(data, size));
  try {
    ips::ConfigChecks checks;
    checks.intrinsics_exist = false;
    checks.model_file_exists = false;
    const ips::DaemonConfig config = ips::parse_config(text, "/nonexistent/ipsd.yaml", checks);
    (void)config;
  } catch (const ips::InputError&) {
  }
  return 0;
}
