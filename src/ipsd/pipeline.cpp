#include "pipeline.h"

#include <chrono>

#include "ips/error.h"
#include "ips/source_factory.h"

namespace ipsd {

std::shared_ptr<const Runtime> build_runtime(const ips::DaemonConfig& config, const Runtime* previous) {
  auto r = std::make_shared<Runtime>();
  r->config = config;
  try {
    r->models = std::make_shared<const ips::ModelSet>(ips::load_model_file(config.model_file));
  } catch (const ips::InputError& e) {
    throw ips::InputError(config.file.string() + ": model_file: " + e.what());
  }
  ips::check_models(config, *r->models);
  for (const auto& cam : config.cameras) {
    r->intrinsics.push_back(ips::load_intrinsics(cam));
    r->mappers.push_back(r->models->find(cam.model));
  }
  r->sizes = config.markers.sizes();
  r->fusion = &ips::find_fusion_method(config.fusion.method, config.file.string() + ": fusion.method");
  if (previous && previous->publisher && previous->config.outputs == config.outputs) {
    r->publisher = previous->publisher;
  } else {
    try {
      r->publisher = std::make_shared<ips::Publisher>(config.outputs);
    } catch (const ips::InputError& e) {
      throw ips::InputError(config.file.string() + ": " + e.what());
    }
  }
  return r;
}

void ObservationQueue::push(ips::FrameObservations batch) {
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

bool ObservationQueue::pop(ips::FrameObservations& out, std::int64_t timeout_ns) {
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
