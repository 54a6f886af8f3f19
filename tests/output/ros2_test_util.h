// A ROS 2-side subscriber for the ros2 output's tests, written directly against the Cyclone DDS
// C API and the generated types (the sink's own code is not used to read).
#pragma once

#include <dds/dds.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>

#include "ros2_msgs.h"

namespace ips::test {

/// Cyclone on loopback only, unicast discovery to 127.0.0.1 (the sandbox has no multicast
/// route; a lab's network needs none of this). Set before the first participant of the process
/// and inherited by the daemon the test starts.
inline void use_loopback_dds() {
  ::setenv("CYCLONEDDS_URI",
           "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
           "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
           "<MaxAutoParticipantIndex>20</MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/></Peers>"
           "</Discovery></Domain></CycloneDDS>",
           1);
}

class DdsParticipant {
 public:
  explicit DdsParticipant(int domain) {
    id = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (id < 0) throw std::runtime_error(std::string("test participant: ") + dds_strretcode(id));
  }
  ~DdsParticipant() { dds_delete(id); }
  DdsParticipant(const DdsParticipant&) = delete;
  DdsParticipant& operator=(const DdsParticipant&) = delete;
  dds_entity_t id;
};

/// A reader of `topic` (DDS name) with type `desc`; reliable or best-effort, keep-last 1000.
inline dds_entity_t make_reader(const DdsParticipant& p, const dds_topic_descriptor_t* desc, const std::string& topic,
                                bool reliable) {
  const dds_entity_t t = dds_create_topic(p.id, desc, topic.c_str(), nullptr, nullptr);
  if (t < 0) throw std::runtime_error("test topic " + topic + ": " + dds_strretcode(t));
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_SECS(1));
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1000);
  const dds_entity_t r = dds_create_reader(p.id, t, q, nullptr);
  dds_delete_qos(q);
  if (r < 0) throw std::runtime_error("test reader " + topic + ": " + dds_strretcode(r));
  return r;
}

/// Takes every available sample of `reader` (of type T), calling `f` on the valid ones;
/// returns how many.
template <typename T>
int take_all(dds_entity_t reader, const std::function<void(const T&)>& f) {
  int n = 0;
  while (true) {
    void* samples[16] = {};
    dds_sample_info_t infos[16];
    const dds_return_t got = dds_take(reader, samples, infos, 16, 16);  // loaned samples
    if (got <= 0) break;
    for (int i = 0; i < got; ++i) {
      if (!infos[i].valid_data) continue;
      f(*static_cast<const T*>(samples[i]));
      ++n;
    }
    dds_return_loan(reader, samples, got);
  }
  return n;
}

/// Polls `done` every 20 ms until it is true or `seconds` passed; returns its last value.
inline bool wait_until(const std::function<bool()>& done, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

}  // namespace ips::test
