// outputs[i] of type subscriptions: robots subscribe for their own unicast stream
// (docs/subscriptions.md, protocol in include/ips/output/wire.h).
#include "ips/output/subscription.h"
#include "output/parse_output.h"

namespace ips::config_detail {

void read_allow_list(MapReader& r, std::vector<std::string>& allow_list) {
  if (r.has("allow")) {
    const YAML::Node allow = r.node("allow");
    if (!allow.IsSequence() || allow.size() == 0)
      r.fail(allow, r.key("allow"), "expected a non-empty list of IPv4 subnets (10.0.0.0/8, 192.168.1.7, ...)");
    allow_list.clear();
    for (std::size_t i = 0; i < allow.size(); ++i) {
      const std::string key = r.key("allow[" + std::to_string(i) + "]");
      const std::string text = allow[i].IsScalar() ? allow[i].Scalar() : "";
      if (!subscription::parse_subnet(text))
        r.fail(allow[i], key,
               "'" + text + "' is not an IPv4 subnet (ADDRESS/BITS with the host bits 0, or one ADDRESS)");
      allow_list.push_back(text);
    }
  }
}

void parse_subscriptions_output(MapReader& r, const YAML::Node& n, OutputConfig& o) {
  SubscriptionSettings& s = o.subscriptions;
  o.address = "0.0.0.0";
  r.get("address", o.address);  // where to listen; default every interface
  int port = 0;
  r.get("port", port, true);
  if (port < 1 || port > 65535) r.fail(n["port"], r.key("port"), "must be 1..65535");
  o.port = static_cast<std::uint16_t>(port);
  read_allow_list(r, s.allow);
  r.get("psk", s.psk);
  r.get("max_subscribers", s.max_subscribers);
  if (s.max_subscribers < 1 || s.max_subscribers > 1024)
    r.fail(n["max_subscribers"], r.key("max_subscribers"), "must be 1..1024");
  r.get_number("max_lease", s.max_lease_s, 1.0, false);
  if (s.max_lease_s > 65535) r.fail(n["max_lease"], r.key("max_lease"), "must be <= 65535 s");
}

}  // namespace ips::config_detail
