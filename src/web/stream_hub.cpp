#include "stream_hub.h"

#include <pthread.h>

#include <chrono>
#include <cmath>

#include <nlohmann/json.hpp>

#include "ips/core/clock.h"

namespace ips::web {

namespace {
// A marker or body not seen for this long leaves the map (the page greys it out well before).
constexpr std::int64_t kForgetNs = 10'000'000'000;
// With nothing new, the table is still re-sent this often (ages grow; a new client catches up).
constexpr std::int64_t kRefreshNs = 1'000'000'000;
}  // namespace

bool StreamClient::push(Message m) {
  bool dropped = false;
  {
    std::lock_guard lock(mutex_);
    if (closed_) return false;
    if (queue_.size() >= kQueue) {
      queue_.pop_front();
      dropped = true;
    }
    queue_.push_back(std::move(m));
  }
  cv_.notify_one();
  return dropped;
}

Message StreamClient::pop(int timeout_ms) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [&] { return closed_ || !queue_.empty(); });
  if (closed_ || queue_.empty()) return nullptr;
  Message m = std::move(queue_.front());
  queue_.pop_front();
  return m;
}

void StreamClient::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

StreamHub::StreamHub(double rate_hz)
    : period_ns_(static_cast<std::int64_t>(std::llround(1e9 / rate_hz))), thread_([this] { run(); }) {}

StreamHub::~StreamHub() { stop(); }

void StreamHub::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    for (auto& c : clients_) c->close();
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void StreamHub::publish(const Datagram& d) {
  std::lock_guard lock(mutex_);
  if (inbox_.size() >= kInbox) {
    inbox_.pop_front();
    ++inbox_dropped;
  }
  inbox_.push_back(d);
}

void StreamHub::set_status(const std::string& json) {
  std::lock_guard lock(mutex_);
  status_ = std::make_shared<const std::string>("event: status\ndata: " + json + "\n\n");
  status_changed_ = true;
}

std::shared_ptr<StreamClient> StreamHub::subscribe(std::size_t max_clients) {
  std::lock_guard lock(mutex_);
  if (stop_ || clients_.size() >= max_clients) {
    ++refused;
    return nullptr;
  }
  auto c = std::make_shared<StreamClient>();
  if (status_) c->push(status_);
  if (markers_) c->push(markers_);
  clients_.push_back(c);
  ++clients_total;
  return c;
}

void StreamHub::unsubscribe(const std::shared_ptr<StreamClient>& c) {
  c->close();
  std::lock_guard lock(mutex_);
  clients_.remove(c);
}

std::size_t StreamHub::clients() const {
  std::lock_guard lock(mutex_);
  return clients_.size();
}

void StreamHub::broadcast(const Message& m) {
  std::lock_guard lock(mutex_);
  for (auto& c : clients_)
    if (c->push(m)) ++dropped;
  ++broadcasts;
}

Message StreamHub::markers_message(std::int64_t now) const {
  const auto age = [now](std::int64_t t) { return 1e-9 * static_cast<double>(now - t); };
  nlohmann::json j;
  j["t_mono_ns"] = now;
  j["update"] = last_update_;
  auto& list = j["markers"] = nlohmann::json::array();
  for (const auto& [id, e] : table_) {
    const MarkerRecord& m = e.record;
    nlohmann::json o{{"id", id},
                     {"x", m.x},
                     {"y", m.y},
                     {"z", m.z},
                     {"yaw", m.yaw},
                     {"cameras", m.camera_mask},
                     {"quality", m.quality},
                     {"spread", m.spread},
                     {"t_mono_ns", e.t_mono_ns},
                     {"age", age(e.t_mono_ns)}};
    if (e.has_velocity) o.update({{"vx", m.vx}, {"vy", m.vy}});  // absent: not measured (as for bodies)
    // What placed it (cameras, ranges) and whether the heading was measured or is held.
    auto& sources = o["sources"] = nlohmann::json::array();
    for (const char* name : wire_source_names(m.sources)) sources.push_back(name);
    o["has_yaw"] = m.has_yaw;
    list.push_back(std::move(o));
  }
  // Bodies (docs/bodies.md): a position-only body (has_yaw false) has no meaningful yaw or q.
  auto& bodies = j["bodies"] = nlohmann::json::array();
  for (const auto& [name, e] : bodies_) {
    const BodyRecord& b = e.record;
    nlohmann::json o{{"name", name},
                     {"x", b.x},
                     {"y", b.y},
                     {"z", b.z},
                     {"yaw", b.yaw},
                     {"has_yaw", b.has_yaw},
                     {"q", {b.qw, b.qx, b.qy, b.qz}},
                     {"cameras", b.camera_mask},
                     {"ids", b.ids},
                     {"id_count", b.id_count},
                     {"quality", b.quality},
                     {"spread", b.spread},
                     {"t_mono_ns", e.t_mono_ns},
                     {"age", age(e.t_mono_ns)}};
    if (b.has_velocity) o.update({{"vx", b.vx}, {"vy", b.vy}, {"vz", b.vz}});  // absent: not measured
    if (b.has_yaw_rate) o["yaw_rate"] = b.yaw_rate;
    auto& sources = o["sources"] = nlohmann::json::array();  // ranges alone: the heading is held
    for (const char* source : wire_source_names(b.sources)) sources.push_back(source);
    bodies.push_back(std::move(o));
  }
  return std::make_shared<const std::string>("event: markers\ndata: " + j.dump() + "\n\n");
}

void StreamHub::merge(const Datagram& d) {
  last_update_ = d.update;
  // Fusion never goes back in time per marker or body; the tables keep it so.
  const auto keep_newest = [&d](auto& entry, const auto& record) {
    const std::int64_t t = d.capture_monotonic_ns + static_cast<std::int64_t>(record.dt_us) * 1000;
    if (t >= entry.t_mono_ns) entry = {record, t, d.has_velocity};
  };
  for (const MarkerRecord& m : d.markers) keep_newest(table_[m.id], m);
  for (const BodyRecord& b : d.bodies) keep_newest(bodies_[b.name], b);
}

bool StreamHub::forget_old(std::int64_t now) {
  bool changed = false;
  const auto sweep = [&](auto& table) {
    for (auto it = table.begin(); it != table.end();) {
      if (now - it->second.t_mono_ns > kForgetNs) {
        it = table.erase(it);
        changed = true;
      } else {
        ++it;
      }
    }
  };
  sweep(table_);
  sweep(bodies_);
  return changed;
}

void StreamHub::run() {
  pthread_setname_np(pthread_self(), "web-fanout");
  std::int64_t last_sent = 0;
  std::deque<Datagram> batch;
  for (;;) {
    Message status;
    {
      std::unique_lock lock(mutex_);
      cv_.wait_for(lock, std::chrono::nanoseconds(period_ns_), [&] { return stop_; });
      if (stop_) return;
      batch.swap(inbox_);
      if (status_changed_) status = status_;
      status_changed_ = false;
    }
    const std::int64_t now = monotonic_ns();
    bool changed = !batch.empty();
    for (const Datagram& d : batch) merge(d);
    batch.clear();
    if (forget_old(now)) changed = true;
    if (status) broadcast(status);
    if (changed || now - last_sent >= kRefreshNs) {
      Message m = markers_message(now);
      {
        std::lock_guard lock(mutex_);
        markers_ = m;
      }
      broadcast(m);
      last_sent = now;
    }
  }
}

}  // namespace ips::web
