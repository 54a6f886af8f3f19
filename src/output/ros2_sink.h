// type ros2: every fused update as ROS 2 messages over DDS (Eclipse Cyclone DDS, C API), with
// the ROS 2 conventions so that `ros2 topic echo` on any ROS 2 machine sees them without a
// bridge: per marker geometry_msgs/PoseStamped on /<prefix>/<name>/pose, nav_msgs/Odometry on
// /<prefix>/<name>/odom (updates with velocity), optionally tf2_msgs/TFMessage on /tf.
//
// publish() never touches DDS: it leaves the update in a one-slot mailbox for the sink's own
// writer thread (a newer update replaces one not yet written, counted as lost), so neither a
// reliable reader's acknowledgements nor DDS's locks and sends can hold up the fusion thread.
// The DDS entities live behind a forward declaration: no DDS header outside ros2_sink.cpp.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "ips/output/output_sink.h"

namespace ips {

class Ros2Sink final : public OutputSink {
 public:
  /// Creates the DDS participant on settings.domain (Cyclone reads its own configuration from
  /// CYCLONEDDS_URI). `where` = "outputs[i]" for error messages. Throws std::runtime_error if
  /// DDS cannot start.
  Ros2Sink(const OutputConfig& config, const std::string& where);
  ~Ros2Sink() override;
  Ros2Sink(const Ros2Sink&) = delete;
  Ros2Sink& operator=(const Ros2Sink&) = delete;

  void publish(const Datagram& update) override;
  /// datagrams = DDS samples written; send_errors = failed writes + updates replaced in the
  /// mailbox before the writer thread got to them; bytes are not counted (DDS serializes).
  OutputStats stats() const override;
  std::int64_t last_latency_ns() const override { return last_latency_ns_.load(std::memory_order_relaxed); }

 private:
  class Writers;  // the DDS participant and writers (ros2_sink.cpp)
  void run();

  Ros2OutputSettings settings_;
  std::string description_;
  std::unique_ptr<Writers> dds_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<Datagram> pending_;
  bool stop_ = false;
  std::atomic<std::uint64_t> samples_{0};
  std::atomic<std::uint64_t> errors_{0};    // DDS writes that failed
  std::atomic<std::uint64_t> replaced_{0};  // updates replaced in the mailbox before the writer took them
  std::atomic<std::int64_t> last_latency_ns_{0};
  std::thread thread_;  // last: starts after everything it uses exists
};

}  // namespace ips
