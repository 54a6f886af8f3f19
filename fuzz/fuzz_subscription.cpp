// The subscription port (output `type: subscriptions`): every datagram any host sends it goes
// through decode_request, with and without a pre-shared key; robots decode the daemon's
// replies with decode_reply; `allow` entries are parsed by parse_subnet. Beyond "no fault":
// a request that decodes re-encodes to exactly the bytes received (the format has one
// spelling per request, so anything else accepted would be a decoder bug), and a reply that
// decodes re-encodes to the same status, lease and cookie.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "ips/output/subscription.h"

namespace sub = ips::subscription;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  for (const char* psk : {"", "lab secret"}) {
    sub::RequestError error = sub::RequestError::kNone;
    const auto request = sub::decode_request(bytes, psk, error);
    if (request) {
      if (error != sub::RequestError::kNone) std::abort();
      const std::vector<std::uint8_t> again = sub::encode_request(*request, psk);
      if (again.size() != size || !std::equal(again.begin(), again.end(), data)) std::abort();
    } else if (error == sub::RequestError::kNone) {
      std::abort();  // refused without a reason
    }
  }
  if (const auto reply = sub::decode_reply(bytes)) {
    const auto again = sub::decode_reply(sub::encode_reply(*reply));
    if (!again || again->status != reply->status || again->lease_s != reply->lease_s || again->cookie != reply->cookie)
      std::abort();
  }
  const std::string text(ips::fuzz::as_text(data, size));
  if (const auto subnet = sub::parse_subnet(text)) {
    if ((subnet->network & ~subnet->mask) != 0 || !subnet->contains(subnet->network)) std::abort();
  }
  return 0;
}
