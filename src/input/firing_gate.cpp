#include "ips/input/firing_gate.h"

#include <algorithm>

namespace ips {

FiringGate::Verdict FiringGate::admit(std::uint32_t tag, std::uint32_t firing, std::int64_t t_mono_ns) {
  Tag& t = tags_[tag];
  if (t.taken.count(firing)) return Verdict::kDuplicate;
  if (t.any && t_mono_ns < t.newest_ns - reorder_window_ns_) return Verdict::kTooOld;
  t.taken.insert(firing);
  t.order.push_back(firing);
  if (t.order.size() > kRemembered) {
    t.taken.erase(t.order.front());
    t.order.pop_front();
  }
  t.newest_ns = t.any ? std::max(t.newest_ns, t_mono_ns) : t_mono_ns;
  t.any = true;
  return Verdict::kAccepted;
}

}  // namespace ips
