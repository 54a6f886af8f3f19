#include "ips/output/output_settings.h"

namespace ips {

std::string OutputConfig::describe() const {
  if (kind == Kind::kRos2) return "ros2 domain " + std::to_string(ros2.domain) + " /" + ros2.prefix;
  const std::string where = address + ":" + std::to_string(port);
  switch (kind) {
    case Kind::kMavlink: return "mavlink " + where + " (" + std::to_string(mavlink.vehicles.size()) + " vehicle(s))";
    case Kind::kSubscriptions: return "subscriptions on " + where;
    default: break;
  }
  const char* kinds[] = {"unicast", "broadcast", "multicast"};
  return std::string(kinds[static_cast<int>(kind)]) + " " + where + " (" + to_string(format) + ")";
}

}  // namespace ips
