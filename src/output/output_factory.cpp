// The one place that maps an output type from the config to its implementation.
#include "ips/output/output_sink.h"
#include "mavlink_sink.h"
#include "ros2_sink.h"
#include "subscription_sink.h"
#include "udp_sink.h"

namespace ips {

std::unique_ptr<OutputSink> make_output_sink(const OutputConfig& config, int index) {
  const std::string where = "outputs[" + std::to_string(index) + "]";
  switch (config.kind) {
    case OutputConfig::Kind::kUnicast:
    case OutputConfig::Kind::kBroadcast:
    case OutputConfig::Kind::kMulticast: return std::make_unique<UdpSink>(config, where);
    case OutputConfig::Kind::kMavlink: return std::make_unique<MavlinkSink>(config, where);
    case OutputConfig::Kind::kSubscriptions: return std::make_unique<SubscriptionSink>(config, where);
    case OutputConfig::Kind::kRos2: return std::make_unique<Ros2Sink>(config, where);
  }
  throw InputError(where + ".type: not an output type this build can open");
}

}  // namespace ips
