#include "ips/ranging/range_observation.h"

namespace ips {

WorldObservation range_fix_observation(const RangeFix& fix, int id, int tag, std::int64_t t_mono_ns,
                                       std::int64_t t_real_ns) {
  WorldObservation o;
  o.id = id;
  o.camera_index = tag;
  o.source = ObservationSource::kRanges;
  o.p_world = fix.position;
  o.covariance = fix.covariance;
  o.has_yaw = false;
  o.t_mono_ns = t_mono_ns;
  o.t_real_ns = t_real_ns;
  return o;
}

}  // namespace ips
