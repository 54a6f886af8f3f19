// The fusion section of the lab's configuration. Everything the asynchronous fusion itself uses
// is its own options struct (TrackFusionOptions, with its defaults); this adds what the daemon
// around it needs. Parsed by src/fusion/parse_fusion.cpp.
#pragma once

#include <string>

#include "ips/fusion/track_fusion.h"

namespace ips {

struct FusionConfig : TrackFusionOptions {
  std::string method = "mean";  ///< mean | area | gauss | median (the per-instant combination)
  double output_rate_hz = 0.0;  ///< 0 = one update per camera frame; > 0 = fixed rate, state predicted
  double max_wait_s = 0.050;    ///< obsolete (frame sets are gone); accepted so old files still load
  /// A camera whose view of a fixed marker is this far from its surveyed position is reported
  /// as possibly moved, metres.
  double fixed_marker_warn_m = 0.03;
};

}  // namespace ips
