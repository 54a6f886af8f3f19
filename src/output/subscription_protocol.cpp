#include "ips/output/subscription.h"

#include <arpa/inet.h>

#include <cstdlib>
#include <cstring>

#include <sodium.h>

namespace ips::subscription {

namespace {

void put_u16(std::vector<std::uint8_t>& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v & 0xff));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}

std::span<const std::uint8_t> as_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

}  // namespace

Mac hmac_sha256(std::span<const std::uint8_t> key, std::span<const std::uint8_t> data) {
  [[maybe_unused]] static const int init = sodium_init();  // once; thread-safe static
  crypto_auth_hmacsha256_state state;
  crypto_auth_hmacsha256_init(&state, key.data(), key.size());
  crypto_auth_hmacsha256_update(&state, data.data(), data.size());
  Mac mac;
  crypto_auth_hmacsha256_final(&state, mac.data());
  return mac;
}

std::vector<std::uint8_t> encode_request(const Request& r, const std::string& psk) {
  const char* magic = IPS_SUB_MAGIC_REQUEST;
  std::vector<std::uint8_t> b(magic, magic + 4);
  b.push_back(IPS_SUB_VERSION);
  b.push_back(static_cast<std::uint8_t>(r.op));
  b.push_back(r.format == WireFormat::kJson ? 1 : 0);
  b.push_back(r.all ? IPS_SUB_FLAG_ALL : 0);
  put_u16(b, r.lease_s);
  const std::vector<std::uint32_t> none;
  const auto& ids = r.all ? none : r.ids;
  put_u16(b, static_cast<std::uint16_t>(ids.size()));
  b.insert(b.end(), r.cookie.begin(), r.cookie.end());
  for (std::uint32_t id : ids) {
    std::uint8_t v[4];
    ips_wire_put_u32(v, id);
    b.insert(b.end(), v, v + 4);
  }
  if (!psk.empty()) {
    const Mac mac = hmac_sha256(as_bytes(psk), b);
    b.insert(b.end(), mac.begin(), mac.end());
  }
  return b;
}

std::optional<Request> decode_request(std::span<const std::uint8_t> bytes, const std::string& psk,
                                      RequestError& error) {
  error = RequestError::kMalformed;
  if (bytes.size() < IPS_SUB_REQUEST_HEADER || std::memcmp(bytes.data(), IPS_SUB_MAGIC_REQUEST, 4) != 0 ||
      bytes[4] != IPS_SUB_VERSION)
    return std::nullopt;
  Request r;
  if (bytes[5] != IPS_SUB_OP_SUBSCRIBE && bytes[5] != IPS_SUB_OP_UNSUBSCRIBE) return std::nullopt;
  r.op = static_cast<Op>(bytes[5]);
  if (bytes[6] > 1) return std::nullopt;
  r.format = bytes[6] == 1 ? WireFormat::kJson : WireFormat::kBinary;
  if ((bytes[7] & ~IPS_SUB_FLAG_ALL) != 0) return std::nullopt;
  r.all = (bytes[7] & IPS_SUB_FLAG_ALL) != 0;
  r.lease_s = ips_wire_get_u16(bytes.data() + 8);
  const std::uint16_t n = ips_wire_get_u16(bytes.data() + 10);
  if (n > IPS_SUB_MAX_IDS || (r.all && n != 0) || (!r.all && n == 0)) return std::nullopt;
  if (r.op == Op::kSubscribe && r.lease_s == 0) return std::nullopt;
  std::memcpy(r.cookie.data(), bytes.data() + 12, r.cookie.size());
  const std::size_t body = IPS_SUB_REQUEST_HEADER + 4u * n;
  const std::size_t want = body + (psk.empty() ? 0 : IPS_SUB_MAC_SIZE);
  if (bytes.size() != want) {
    // The right body with a missing or surplus MAC is a key mismatch, not garbage.
    if (bytes.size() == body || bytes.size() == body + IPS_SUB_MAC_SIZE) error = RequestError::kBadKey;
    return std::nullopt;
  }
  for (std::size_t i = 0; i < n; ++i) r.ids.push_back(ips_wire_get_u32(bytes.data() + IPS_SUB_REQUEST_HEADER + 4 * i));
  if (!psk.empty()) {
    const Mac mac = hmac_sha256(as_bytes(psk), bytes.first(body));
    if (crypto_verify_32(mac.data(), bytes.data() + body) != 0) {  // constant time
      error = RequestError::kBadKey;
      return std::nullopt;
    }
  }
  error = RequestError::kNone;
  return r;
}

std::vector<std::uint8_t> encode_reply(const Reply& r) {
  const char* magic = IPS_SUB_MAGIC_REPLY;
  std::vector<std::uint8_t> b(magic, magic + 4);
  b.push_back(IPS_SUB_VERSION);
  b.push_back(static_cast<std::uint8_t>(r.status));
  put_u16(b, 0);
  put_u16(b, r.lease_s);
  put_u16(b, 0);
  b.insert(b.end(), r.cookie.begin(), r.cookie.end());
  return b;
}

std::optional<Reply> decode_reply(std::span<const std::uint8_t> bytes) {
  if (bytes.size() != IPS_SUB_REPLY_SIZE || std::memcmp(bytes.data(), IPS_SUB_MAGIC_REPLY, 4) != 0 ||
      bytes[4] != IPS_SUB_VERSION || bytes[5] < IPS_SUB_CHALLENGE || bytes[5] > IPS_SUB_UNSUBSCRIBED)
    return std::nullopt;
  Reply r;
  r.status = static_cast<Status>(bytes[5]);
  r.lease_s = ips_wire_get_u16(bytes.data() + 8);
  std::memcpy(r.cookie.data(), bytes.data() + 12, r.cookie.size());
  return r;
}

std::optional<Subnet> parse_subnet(const std::string& text) {
  const auto slash = text.find('/');
  const std::string host = text.substr(0, slash);
  in_addr a{};
  if (::inet_pton(AF_INET, host.c_str(), &a) != 1) return std::nullopt;
  int bits = 32;
  if (slash != std::string::npos) {
    const std::string b = text.substr(slash + 1);
    char* end = nullptr;
    const long v = std::strtol(b.c_str(), &end, 10);
    if (b.empty() || *end != '\0' || v < 0 || v > 32) return std::nullopt;
    bits = static_cast<int>(v);
  }
  Subnet s;
  s.mask = bits == 0 ? 0u : ~std::uint32_t{0} << (32 - bits);
  const std::uint32_t address = ntohl(a.s_addr);
  if ((address & ~s.mask) != 0) return std::nullopt;  // host bits set: almost surely a typo
  s.network = address;
  return s;
}

}  // namespace ips::subscription
