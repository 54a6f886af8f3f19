// The range input (ranging: in the config): every datagram any host sends to its port goes
// through RangeAdmission (subnet, rate, decode_range_firing with or without a key, tags,
// references, clock, duplicates, order). Beyond "no fault": a datagram that decodes with the
// version-1 entry size and zero reserved fields re-encodes to exactly the bytes received (one
// spelling per firing, so anything else accepted would be a decoder bug); a refusal always
// says why; a firing taken keeps only configured references and a time not in the future.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "ips/input/range_admission.h"
#include "ips/input/range_wire.h"

namespace {

ips::RangeInputSettings settings(const std::string& psk) {
  ips::RangeInputSettings s;
  s.allow = {"10.0.0.0/8"};
  s.psk = psk;
  s.tags = {1, 2, 3, 7};
  s.anchors = {1, 2, 3, 4, 5, 6};
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  for (const char* psk : {"", "lab secret"}) {
    ips::RangeDatagramError error = ips::RangeDatagramError::kNone;
    std::string why;
    const auto firing = ips::decode_range_firing(bytes, psk, error, why);
    if (firing) {
      if (error != ips::RangeDatagramError::kNone) std::abort();
      const bool canonical = ips_wire_get_u16(data + IPS_RANGE_OFF_ENTRY_SIZE) == IPS_RANGE_ENTRY_SIZE &&
                             ips_wire_get_u16(data + IPS_RANGE_OFF_RESERVED) == 0 &&
                             ips_wire_get_u32(data + IPS_RANGE_OFF_RESERVED2) == 0;
      if (canonical) {
        const std::vector<std::uint8_t> again = ips::encode_range_firing(*firing, psk);
        if (again.size() != size || !std::equal(again.begin(), again.end(), data)) std::abort();
      }
    } else if (error == ips::RangeDatagramError::kNone || why.empty()) {
      std::abort();  // refused without a reason
    }

    // Twice through one admission: the second is a duplicate if the first was taken.
    static constexpr std::int64_t kMono = 1'000'000'000'000, kReal = 1'800'000'000'000'000'000;
    ips::RangeAdmission admission(settings(psk), "ranging");
    for (int round = 0; round < 2; ++round) {
      const auto taken = admission.admit(bytes, 0x0A000001u, 4000, kMono, kReal);
      if (!taken) continue;
      if (round == 1) std::abort();
      if (taken->t_mono_ns > kMono + 1'000'000'000) std::abort();
      for (const ips::RangeEntry& e : taken->firing.entries)
        if (!(e.reference_is_tag ? admission.settings().tags : admission.settings().anchors).count(e.reference))
          std::abort();
    }
    const auto& c = admission.counters();
    std::uint64_t refused = 0;
    for (auto n : c.refused) refused += n;
    if (c.datagrams != 2 || c.accepted + refused != 2) std::abort();
  }
  return 0;
}
