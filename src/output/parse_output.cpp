// outputs[i]: where and how the fused stream is sent. One parser per output type; the type
// decides which other keys are allowed (an unknown key is an error naming it).
#include "output/parse_output.h"

namespace ips::config_detail {

namespace {

/// unicast | broadcast | multicast: ipsd's own datagrams (include/ips/output/wire.h) over UDP.
void parse_udp_output(MapReader& r, const YAML::Node& n, OutputConfig& o) {
  r.get("address", o.address, true);
  int port = 0;
  r.get("port", port, true);
  if (port < 1 || port > 65535) r.fail(n["port"], r.key("port"), "must be 1..65535");
  o.port = static_cast<std::uint16_t>(port);
  std::string format = "binary";
  r.get("format", format);
  try {
    o.format = parse_wire_format(format, r.key("format"));
  } catch (const InputError&) {
    r.fail(n["format"], r.key("format"), std::string("unknown value '") + format + "' (binary|json)");
  }
  r.get("ttl", o.ttl);
  if (o.ttl < 0 || o.ttl > 255) r.fail(n["ttl"], r.key("ttl"), "must be 0..255");
  r.get("interface", o.interface);
}

}  // namespace

OutputConfig parse_output(const YAML::Node& n, int index, const std::string& file) {
  MapReader r(n, "outputs[" + std::to_string(index) + "]", file);
  OutputConfig o;
  o.kind = pick<OutputConfig::Kind>(r, "type",
                                    {{"unicast", OutputConfig::Kind::kUnicast},
                                     {"broadcast", OutputConfig::Kind::kBroadcast},
                                     {"multicast", OutputConfig::Kind::kMulticast},
                                     {"mavlink", OutputConfig::Kind::kMavlink},
                                     {"subscriptions", OutputConfig::Kind::kSubscriptions},
                                     {"ros2", OutputConfig::Kind::kRos2}},
                                    o.kind, true);
  switch (o.kind) {
    case OutputConfig::Kind::kUnicast:
    case OutputConfig::Kind::kBroadcast:
    case OutputConfig::Kind::kMulticast: parse_udp_output(r, n, o); break;
    case OutputConfig::Kind::kMavlink: parse_mavlink_output(r, n, o, file); break;
    case OutputConfig::Kind::kSubscriptions: parse_subscriptions_output(r, n, o); break;
    case OutputConfig::Kind::kRos2: parse_ros2_output(r, n, o.ros2); break;
  }
  r.finish();
  return o;
}

}  // namespace ips::config_detail
