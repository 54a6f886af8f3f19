#include "pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "ips/config/source_factory.h"
#include "ips/core/error.h"

namespace ipsd {

std::shared_ptr<const Runtime> build_runtime(const ips::DaemonConfig& config, const Runtime* previous,
                                             bool validate_only) {
  auto r = std::make_shared<Runtime>();
  r->config = config;
  try {
    // Without overhead cameras (every camera on a robot) there may be no model file.
    r->models = std::make_shared<const ips::ModelSet>(
        config.model_file.empty() ? ips::ModelSet{} : ips::load_model_file(config.model_file));
  } catch (const ips::InputError& e) {
    throw ips::InputError(config.file.string() + ": model_file: " + e.what());
  }
  ips::check_models(config, *r->models);
  for (const auto& cam : config.cameras) {
    r->intrinsics.push_back(ips::load_intrinsics(cam));
    const auto riding = config.on_robot.find(cam.index);
    r->mappers.push_back(riding == config.on_robot.end() ? r->models->find(cam.model) : nullptr);
    std::shared_ptr<const ips::CeilingMap> map;
    if (riding != config.on_robot.end()) {
      try {
        map = std::make_shared<const ips::CeilingMap>(ips::CeilingMap::load(riding->second.map));
      } catch (const ips::InputError& e) {
        throw ips::InputError(config.file.string() + ": cameras[" + std::to_string(cam.index) +
                              "].on_robot.map: " + e.what());
      }
      if (!map->dictionary.empty() && map->dictionary != config.markers.dictionary)
        throw ips::InputError(config.file.string() + ": cameras[" + std::to_string(cam.index) +
                              "].on_robot.map: " + riding->second.map.string() + " was made with " + map->dictionary +
                              ", but markers.dictionary is " + config.markers.dictionary);
    }
    r->ceiling_maps.push_back(std::move(map));
  }
  r->sizes = config.markers.sizes();
  r->fusion = &ips::find_fusion_method(config.fusion.method, config.file.string() + ": fusion.method");
  if (!config.bodies.empty()) r->bodies = std::make_shared<const ips::BodyEstimator>(config.bodies);
  if (previous && previous->publisher && previous->config.outputs == config.outputs) {
    r->publisher = previous->publisher;
  } else {
    try {
      r->publisher = std::make_shared<ips::Publisher>(config.outputs, validate_only);
    } catch (const ips::InputError& e) {
      throw ips::InputError(config.file.string() + ": " + e.what());
    }
  }
  return r;
}

void LatencyWindow::add(std::int64_t processing_ns, std::int64_t capture_ns) {
  std::lock_guard lock(mutex_);
  if (processing_.size() >= kMaxSamples) return;
  processing_.push_back(processing_ns);
  capture_.push_back(capture_ns);
}

void LatencyWindow::rotate() {
  std::lock_guard lock(mutex_);
  last_processing_.swap(processing_);
  last_capture_.swap(capture_);
  processing_.clear();
  capture_.clear();
  rotated_ = true;
}

LatencyWindow::Percentiles LatencyWindow::of(std::vector<std::int64_t> v) {
  Percentiles p;
  p.samples = v.size();
  if (v.empty()) return p;
  std::sort(v.begin(), v.end());
  auto at = [&v](double q) {  // nearest rank
    const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
    return 1e-6 * static_cast<double>(v[std::clamp<std::size_t>(rank, 1, v.size()) - 1]);
  };
  p.p50_ms = at(0.50);
  p.p99_ms = at(0.99);
  return p;
}

LatencyWindow::Percentiles LatencyWindow::processing() const {
  std::lock_guard lock(mutex_);
  return of(rotated_ ? last_processing_ : processing_);
}

LatencyWindow::Percentiles LatencyWindow::capture() const {
  std::lock_guard lock(mutex_);
  return of(rotated_ ? last_capture_ : capture_);
}

void ObservationQueue::push(CameraBatch batch) {
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
    if (queue_.size() >= capacity_) {
      queue_.pop_front();
      ++dropped_;
    }
    queue_.push_back(std::move(batch));
  }
  cv_.notify_one();
}

bool ObservationQueue::pop(CameraBatch& out, std::int64_t timeout_ns) {
  std::unique_lock lock(mutex_);
  if (!cv_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [this] { return closed_ || !queue_.empty(); }))
    return false;
  if (queue_.empty()) return false;
  out = std::move(queue_.front());
  queue_.pop_front();
  return true;
}

void ObservationQueue::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

}  // namespace ipsd
