// `ips record` session folders, read by `ips survey` (and copied between machines by hand):
// session.txt plus one <camera>.det file per camera. The input is split at its first NUL byte:
// before it session.txt, after it the text of both a.det and b.det (the names the seeds'
// headers use; without a NUL, the whole input is a.det under a fixed valid header). A session
// loads or throws ips::InputError; what loads has only finite corners and ids >= 0.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "fuzz_util.h"
#include "ips/core/error.h"
#include "ips/survey/survey.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = ips::fuzz::as_text(data, size);
  const std::size_t nul = text.find('\0');
  std::string_view header = "ips-record 1\nconfig ipsd.yaml\nfingerprint 0123456789abcdef\ncamera a a.det\n";
  std::string_view det = text;
  if (nul != std::string_view::npos) {
    header = text.substr(0, nul);
    det = text.substr(nul + 1);
  }
  ips::fuzz::write_file("session.txt", header);
  ips::fuzz::write_file("a.det", det);
  ips::fuzz::write_file("b.det", det);
  try {
    const auto session = ips::survey::load_session(ips::fuzz::scratch());
    for (const auto& camera : session.cameras)
      for (const auto& d : camera.detections) {
        if (d.id < 0) std::abort();
        for (const auto& p : d.corners)
          if (!std::isfinite(p.x) || !std::isfinite(p.y)) std::abort();
      }
  } catch (const ips::InputError&) {
  }
  return 0;
}
