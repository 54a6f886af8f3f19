// The range fixer tests' lab: four anchors at the corners of a 4 x 3 m room at two heights, tag 7
// published as marker 20.
#pragma once

#include "ips/input/ranging_settings.h"

namespace ips::test {

inline RangingConfig ranging_lab() {
  RangingConfig c;
  c.anchors[1].position = {0, 0, 2.5};
  c.anchors[2].position = {4, 0, 1.0};
  c.anchors[3].position = {4, 3, 2.5};
  c.anchors[4].position = {0, 3, 1.0};
  c.tags[7] = RangingTag::on_marker(20);
  return c;
}

}  // namespace ips::test
