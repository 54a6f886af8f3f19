#include "status.h"

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "ips/core/error.h"
#include "ips/core/image_buffer_pool.h"

namespace ipsd {

void RateSampler::sample(const std::vector<CameraStats*>& cameras, const std::vector<std::string>& names,
                         const FusionStats& fusion, std::int64_t now_ns) {
  const double dt = previous_ns_ > 0 ? 1e-9 * static_cast<double>(now_ns - previous_ns_) : 0.0;
  previous_.resize(cameras.size());
  rates_.resize(cameras.size());
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    CameraStats& s = *cameras[i];
    CameraRates& r = rates_[i];
    Previous& p = previous_[i];
    r.name = names[i];
    const std::uint64_t frames = s.frames, detect_ns = s.detect_ns, markers = s.markers, queue_ns = s.queue_ns;
    const std::uint64_t df = frames - p.frames;
    r.fps = dt > 0 ? static_cast<double>(df) / dt : 0.0;
    r.detect_ms = df ? 1e-6 * static_cast<double>(detect_ns - p.detect_ns) / static_cast<double>(df) : 0.0;
    r.markers = df ? static_cast<double>(markers - p.markers) / static_cast<double>(df) : 0.0;
    r.queue_ms = df ? 1e-6 * static_cast<double>(queue_ns - p.queue_ns) / static_cast<double>(df) : 0.0;
    p = {frames, detect_ns, markers, queue_ns};
    r.frames = frames;
    r.detect_ns_total = detect_ns;
    r.queue_ns_total = queue_ns;
    r.acquire_ns_total = s.acquire_ns;
    r.markers_total = markers;
    r.drops = s.drops;
    r.corrupt = s.corrupt;
    r.failures = s.failures;
    r.no_height = s.no_height;
    r.over_budget = s.over_budget;
    r.restart_markers = s.restart_markers;
    r.restart_damaged = s.restart_damaged;
    r.body_rejected = s.body_rejected;
    r.robot_poses = s.robot_poses;
    r.robot_unplaced = s.robot_unplaced;
    r.ceiling_outliers = s.ceiling_outliers;
    r.on_robot = r.robot_poses + r.robot_unplaced > 0;
    const int state = s.state;
    r.state = state == static_cast<int>(CameraState::kOpen)   ? "open"
              : state == static_cast<int>(CameraState::kDown) ? "down"
                                                              : "starting";
    std::lock_guard lock(s.error_mutex);
    r.last_error = s.last_error;
    r.source = s.source;
  }
  const std::uint64_t updates = fusion.updates;
  updates_per_s_ = dt > 0 ? static_cast<double>(updates - previous_updates_) / dt : 0.0;
  previous_updates_ = updates;
  previous_ns_ = now_ns;
}

std::vector<std::string> status_lines(const RateSampler& rates, FusionStats& fusion, std::uint64_t queue_drops) {
  std::vector<std::string> lines;
  for (const auto& c : rates.cameras()) {
    std::string line = fmt::format(
        "{}: {:.1f} fps, queue {:.1f} ms, detect {:.1f} ms, {:.1f} markers, drops {}, corrupt {}, errors {}, {}",
        c.name, c.fps, c.queue_ms, c.detect_ms, c.markers, c.drops, c.corrupt, c.failures, c.state);
    if (c.over_budget) line += fmt::format(", {} over budget", c.over_budget);
    if (c.restart_markers) line += ", restart markers";
    if (c.restart_damaged) line += fmt::format(", {} with misplaced restart markers", c.restart_damaged);
    if (c.no_height) line += fmt::format(", {} without height", c.no_height);
    if (c.body_rejected) line += fmt::format(", {} body views rejected", c.body_rejected);
    if (c.on_robot)
      line += fmt::format(", robot placed {} / unplaced {} frames, {} ceiling outliers", c.robot_poses,
                          c.robot_unplaced, c.ceiling_outliers);
    if (c.state != "open" && !c.last_error.empty()) line += " (" + c.last_error + ")";
    lines.push_back(line);
  }
  const auto proc = fusion.latency.processing();
  const auto cap = fusion.latency.capture();
  std::string out = fmt::format(
      "fusion: {:.1f} updates/s, processing latency p50 {:.1f} p99 {:.1f} ms, capture latency p50 {:.1f} p99 {:.1f} "
      "ms, "
      "late {}, too old {}, queue drops {}",
      rates.updates_per_s(), proc.p50_ms, proc.p99_ms, cap.p50_ms, cap.p99_ms, fusion.late.load(),
      fusion.too_old.load(), queue_drops);
  std::lock_guard lock(fusion.outputs_mutex);
  for (const auto& o : fusion.outputs) {
    out += fmt::format("; {}: sent {}, errors {}", o.description, o.datagrams, o.send_errors);
    for (const auto& [name, value] : o.counters) out += fmt::format(", {} {}", name, value);
  }
  lines.push_back(out);
  return lines;
}

std::string systemd_status(const RateSampler& rates) {
  std::string s;
  for (const auto& c : rates.cameras()) {
    if (!s.empty()) s += ", ";
    s += c.state == "open" ? fmt::format("{} {:.1f} fps", c.name, c.fps) : c.name + " " + c.state;
  }
  return s;
}

nlohmann::json status_json(const RateSampler& rates, FusionStats& fusion, std::uint64_t queue_drops,
                           const Runtime& runtime, std::int64_t started_mono_ns, std::int64_t synthetic_epoch_mono_ns) {
  nlohmann::json j;
  j["type"] = "ipsd.status";
  j["version"] = IPS_VERSION;
  j["pid"] = static_cast<long>(::getpid());
  j["config"] = runtime.config.file.string();
  j["model_file"] = runtime.config.model_file.string();
  j["started_mono_ns"] = started_mono_ns;
  j["synthetic_epoch_mono_ns"] = synthetic_epoch_mono_ns;
  j["fusion_method"] = runtime.config.fusion.method;
  j["updates"] = fusion.updates.load();
  j["updates_per_s"] = rates.updates_per_s();
  j["latency_ms"] = 1e-6 * static_cast<double>(fusion.last_latency_ns.load());
  // Over the last status interval; null when there were no samples.
  auto percentiles = [](const LatencyWindow::Percentiles& p) {
    nlohmann::json o;
    o["p50"] = p.samples ? nlohmann::json(p.p50_ms) : nlohmann::json(nullptr);
    o["p99"] = p.samples ? nlohmann::json(p.p99_ms) : nlohmann::json(nullptr);
    o["samples"] = p.samples;
    return o;
  };
  j["processing_latency_ms"] = percentiles(fusion.latency.processing());
  j["capture_latency_ms"] = percentiles(fusion.latency.capture());
  j["fusion_late"] = fusion.late.load();
  j["fusion_too_old"] = fusion.too_old.load();
  j["fusion_held_for_cameras"] = fusion.held_for_cameras.load();  // fusion.camera_hold
  j["fusion_camera_hold_s"] = fusion.camera_hold_s.load();        // ... as applied: >= the configured
  j["queue_drops"] = queue_drops;
  const ips::ImageBufferPoolStats pool = ips::image_buffer_pool_stats();
  j["image_buffers"] = {{"reused", pool.reused},
                        {"allocated", pool.allocated},
                        {"released", pool.released},
                        {"cached_mib", static_cast<double>(pool.cached_bytes) / (1 << 20)},
                        {"in_use_mib", static_cast<double>(pool.in_use_bytes) / (1 << 20)}};
  j["cameras"] = nlohmann::json::array();
  for (const auto& c : rates.cameras()) {
    j["cameras"].push_back({{"name", c.name},
                            {"source", c.source},
                            {"state", c.state},
                            {"fps", c.fps},
                            {"queue_ms", c.queue_ms},
                            {"detect_ms", c.detect_ms},
                            {"markers", c.markers},
                            {"frames", c.frames},
                            {"drops", c.drops},
                            {"over_budget", c.over_budget},
                            {"restart_markers", c.restart_markers},
                            {"restart_damaged", c.restart_damaged},
                            {"corrupt", c.corrupt},
                            {"errors", c.failures},
                            {"no_height", c.no_height},
                            {"body_rejected", c.body_rejected},
                            {"robot_poses", c.robot_poses},
                            {"robot_unplaced", c.robot_unplaced},
                            {"ceiling_outliers", c.ceiling_outliers},
                            {"last_error", c.last_error},
                            {"detect_s_total", 1e-9 * static_cast<double>(c.detect_ns_total)},
                            {"queue_s_total", 1e-9 * static_cast<double>(c.queue_ns_total)},
                            {"acquire_s_total", 1e-9 * static_cast<double>(c.acquire_ns_total)},
                            {"markers_total", c.markers_total}});
  }
  j["outputs"] = nlohmann::json::array();
  std::lock_guard lock(fusion.outputs_mutex);
  for (const auto& o : fusion.outputs) {
    j["outputs"].push_back(
        {{"output", o.description}, {"datagrams", o.datagrams}, {"bytes", o.bytes}, {"send_errors", o.send_errors}});
    for (const auto& [name, value] : o.counters) j["outputs"].back()[name] = value;
  }
  return j;
}

StatusSocket::StatusSocket(const std::string& path) : path_(path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) throw ips::InputError("status.socket: path too long: " + path);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw ips::InputError(std::string("status.socket: socket: ") + std::strerror(errno));
  ::unlink(path.c_str());  // a stale socket of a previous run
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd_, 8) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    throw ips::InputError("status.socket: cannot listen on " + path + ": " + std::strerror(err));
  }
  // Readable by the daemon's group whatever the umask (the unit's UMask=0027 would leave the
  // group without the write permission connect() needs): a lab member in group ipsd runs
  // `ips status` without sudo. Others stay out (the status names files and addresses).
  if (::chmod(path.c_str(), kSocketMode) != 0)
    spdlog::warn("status.socket: cannot chmod {} to {:o}: {}", path, kSocketMode, std::strerror(errno));
}

StatusSocket::~StatusSocket() {
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
}

StatusSocket::StatusSocket(StatusSocket&& o) noexcept : fd_(o.fd_), path_(std::move(o.path_)) { o.fd_ = -1; }

StatusSocket& StatusSocket::operator=(StatusSocket&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) {
      ::close(fd_);
      ::unlink(path_.c_str());
    }
    fd_ = o.fd_;
    path_ = std::move(o.path_);
    o.fd_ = -1;
  }
  return *this;
}

void StatusSocket::serve(const std::string& text) {
  const int client = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (client < 0) return;
  std::size_t off = 0;
  while (off < text.size()) {
    const ssize_t n = ::send(client, text.data() + off, text.size() - off, MSG_NOSIGNAL);
    if (n <= 0) break;  // a client that does not read gets what fit in the socket buffer
    off += static_cast<std::size_t>(n);
  }
  ::close(client);
}

}  // namespace ipsd
