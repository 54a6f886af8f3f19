#include "ips/output/publisher.h"

namespace ips {

Publisher::Publisher(const std::vector<OutputConfig>& outputs, bool validate_only) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const OutputConfig::Kind kind = outputs[i].kind;
    if (validate_only && (kind == OutputConfig::Kind::kSubscriptions || kind == OutputConfig::Kind::kRos2)) continue;
    sinks_.push_back(make_output_sink(outputs[i], static_cast<int>(i)));
  }
}

Publisher::~Publisher() = default;

void Publisher::publish(const Datagram& update) {
  for (auto& sink : sinks_) {
    sink->publish(update);
    if (const std::int64_t latency = sink->last_latency_ns(); latency != 0) last_latency_ns_ = latency;
  }
}

std::vector<OutputStats> Publisher::stats() const {
  std::vector<OutputStats> s;
  for (const auto& sink : sinks_) s.push_back(sink->stats());
  return s;
}

}  // namespace ips
