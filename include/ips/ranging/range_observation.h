// A solved range fix as what fusion takes: a world observation of source kRanges, with the
// fix's covariance and no heading. Fusion publishes it where no camera sees the object and
// weighs it against the cameras by covariance where one does (ips/fusion/track_fusion.h).
#pragma once

#include <cstdint>

#include "ips/core/observation.h"
#include "ips/ranging/multilateration.h"

namespace ips {

/// `fix` (ok) of ranging tag `tag` that belongs to marker (or body) `id`, fired at the given
/// times (this host's clocks). The tag is the stream: its fixes are fitted for velocity
/// together, apart from the cameras' and from other tags'.
WorldObservation range_fix_observation(const RangeFix& fix, int id, int tag, std::int64_t t_mono_ns,
                                       std::int64_t t_real_ns);

}  // namespace ips
