// Which firings of a ranging tag the daemon takes: the same order rule as camera frames.
//  - A firing number already taken from that tag is a duplicate (a retransmission, a
//    duplicated packet): dropped. The last kRemembered numbers per tag are remembered.
//  - A firing whose time is more than `reorder_window` before the newest one taken from that
//    tag is too old: dropped (fusion would merge it without publishing anything from it).
//  - Anything else is taken, in whatever order it arrives; fusion orders by time.
// Not thread-safe: owned by the range input's receive thread.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <set>

namespace ips {

class FiringGate {
 public:
  enum class Verdict { kAccepted, kDuplicate, kTooOld };
  static constexpr std::size_t kRemembered = 256;

  explicit FiringGate(std::int64_t reorder_window_ns) : reorder_window_ns_(reorder_window_ns) {}

  Verdict admit(std::uint32_t tag, std::uint32_t firing, std::int64_t t_mono_ns);

 private:
  struct Tag {
    std::int64_t newest_ns = 0;
    bool any = false;
    std::set<std::uint32_t> taken;
    std::deque<std::uint32_t> order;  // of `taken`, oldest first, to forget beyond kRemembered
  };
  std::int64_t reorder_window_ns_;
  std::map<std::uint32_t, Tag> tags_;
};

}  // namespace ips
