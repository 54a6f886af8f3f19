// The scene's ceiling as an inside-out map: every marker printed face down on the ceiling
// (markers[].facing: down), exactly where the scene puts it. What a perfect `ips map` would
// find; `ips sim drive` writes it as map.json.
#pragma once

#include "ips/insideout/ceiling_map.h"
#include "ips/sim/scene.h"

namespace ips::sim {

/// The scene's ceiling markers (none: an empty map).
CeilingMap ceiling_map(const Scene& scene);

}  // namespace ips::sim
