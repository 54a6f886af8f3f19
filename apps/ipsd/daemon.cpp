#include "daemon.h"

#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

#include <spdlog/spdlog.h>

#include "ips/config/source_factory.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "signals.h"
#include "web_link.h"

namespace ipsd {

namespace {
constexpr std::int64_t kSampleNs = 1'000'000'000;  // rates and STATUS= refresh period
constexpr int kPollMs = 100;                       // main loop wake-up period
// main.cpp keeps freed memory in glibc's arenas (no trimming: faulting image buffers in again on
// every frame cost ~10 % CPU). Frames are steady, but a fault is not: a camera reopened
// (unplug/replug) or a restarted camera thread set allocates in whatever arena its thread gets,
// and each arena keeps its own high-water mark, so resident memory climbed in steps at faults
// (the one-hour soak: 131 -> 213 MiB, live heap flat). Handing the free pages back once a minute
// and after a camera restart bounds it; a few ms on the main thread, nothing per frame.
constexpr std::int64_t kTrimNs = 60'000'000'000;

void release_free_memory(const char* why) {
  const std::int64_t t0 = ips::monotonic_ns();
  const int released = malloc_trim(0);
  spdlog::debug("memory: malloc_trim ({}) took {:.1f} ms{}", why, static_cast<double>(ips::monotonic_ns() - t0) / 1e6,
                released ? "" : ", nothing to release");
}
}  // namespace

struct Daemon::Pipeline {
  ObservationQueue queue;
  std::unique_ptr<ips::FrameScheduler> scheduler;
  std::unique_ptr<FrameWorkers> workers;
  std::vector<std::unique_ptr<CameraStats>> camera_stats;
  std::vector<CameraStats*> camera_ptrs;
  std::vector<std::string> names;
  FusionStats fusion_stats;
  std::vector<std::unique_ptr<CameraWorker>> cameras;
  ips::FixedMarkerMonitor fixed{{}, {}};  // configured by the fusion thread; outlives it
  std::unique_ptr<FusionWorker> fusion;
  RateSampler rates;
};

Daemon::Daemon(std::filesystem::path config_path, Mode mode) : config_path_(std::move(config_path)) {
  const ips::DaemonConfig config = ips::load_config(config_path_);
  spdlog::set_level(spdlog::level::from_str(config.log_level));
  runtime_.set(build_runtime(config, nullptr, mode == Mode::kCheck));
  if (mode == Mode::kRun && !config.status.socket.empty()) status_socket_.emplace(config.status.socket);
  // The range input binds at start, so a taken port stops ipsd (exit 2) naming ranging.port.
  if (mode == Mode::kRun && config.ranging.enabled())
    ranges_ = std::make_unique<RangeLink>(config.ranging, latest_states_);
}

Daemon::~Daemon() { stop_pipeline(); }

std::vector<ips::SourceFactory> Daemon::make_factories(const ips::DaemonConfig& config) const {
  ips::SourceContext context;
  context.synthetic_epoch_mono_ns = synthetic_epoch_ns_;
  std::vector<ips::SourceFactory> factories;
  for (const auto& cam : config.cameras) factories.push_back(ips::make_source_factory(cam, context));
  return factories;
}

bool Daemon::start_pipeline(std::shared_ptr<const Runtime> runtime, std::vector<ips::SourceFactory> factories,
                            bool at_start) {
  auto p = std::make_unique<Pipeline>();
  const ips::DaemonConfig& config = runtime->config;
  for (const auto& cam : config.cameras) {
    p->camera_stats.push_back(std::make_unique<CameraStats>());
    p->camera_ptrs.push_back(p->camera_stats.back().get());
    p->names.push_back(cam.name);
  }
  // A frame's budget: processing.budget, or one frame period of its camera.
  std::vector<std::int64_t> budgets;
  for (const auto& cam : config.cameras)
    budgets.push_back(
        std::llround(1e9 * (config.processing.budget_s > 0 ? config.processing.budget_s : 1.0 / cam.fps)));
  p->scheduler = std::make_unique<ips::FrameScheduler>(std::move(budgets));
  std::vector<CameraWorker*> processors;
  for (const auto& cam : config.cameras) {
    p->cameras.push_back(std::make_unique<CameraWorker>(cam, std::move(factories[static_cast<std::size_t>(cam.index)]),
                                                        runtime_, *p->scheduler, p->queue,
                                                        *p->camera_stats[static_cast<std::size_t>(cam.index)]));
    processors.push_back(p->cameras.back().get());
  }
  const int workers = config.processing.workers > 0
                          ? config.processing.workers
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  p->workers = std::make_unique<FrameWorkers>(*p->scheduler, std::move(processors), workers);
  runtime_.set(std::move(runtime));
  // Open every camera once before anything runs: a required camera that is absent stops the
  // start; the others are retried by their thread with back-off.
  for (std::size_t i = 0; i < p->cameras.size(); ++i) {
    if (!p->cameras[i]->open_first() && config.cameras[i].required && at_start) {
      spdlog::error("{}: required camera cannot be opened: {}", config.cameras[i].name,
                    p->cameras[i]->supervisor().last_error());
      return false;
    }
  }
  p->fusion = std::make_unique<FusionWorker>(runtime_, p->queue, p->camera_ptrs, p->fusion_stats);
  p->fusion->set_fixed_monitor(&p->fixed);
  p->fusion->set_latest_states(&latest_states_);
  if (web_) {
    const auto taps = web_->set_cameras(p->names);
    for (std::size_t i = 0; i < p->cameras.size(); ++i) p->cameras[i]->set_tap(taps[i]);
    p->fusion->set_web(web_.get());
    web_->set_layout(web_layout(*runtime_.get()));
  }
  p->fusion->start();
  if (ranges_) ranges_->attach(&p->queue);
  p->workers->start();
  for (auto& c : p->cameras) c->start();
  pipeline_ = std::move(p);
  return true;
}

void Daemon::stop_pipeline() {
  if (!pipeline_) return;
  if (ranges_) ranges_->attach(nullptr);
  for (auto& c : pipeline_->cameras) c->request_stop();
  pipeline_->workers->request_stop();
  pipeline_->scheduler->close();
  pipeline_->fusion->request_stop();
  pipeline_->queue.close();
  for (auto& c : pipeline_->cameras) c->join();
  pipeline_->workers->join();
  pipeline_->fusion->join();
  pipeline_.reset();
}

void Daemon::reload() {
  sd_notify(0, "RELOADING=1\nSTATUS=reloading the configuration");
  const std::shared_ptr<const Runtime> old = runtime_.get();
  try {
    const ips::DaemonConfig config = ips::load_config(config_path_);
    std::shared_ptr<const Runtime> fresh = build_runtime(config, old.get());
    std::optional<StatusSocket> socket;
    if (config.status.socket != old->config.status.socket && !config.status.socket.empty())
      socket.emplace(config.status.socket);
    // A changed ranging: section gets a new input, bound before the old one closes (the port
    // is shared for that moment); its firing gate and counters start afresh.
    std::unique_ptr<RangeLink> ranges;
    const bool ranging_changed = config.ranging != old->config.ranging;
    if (ranging_changed && config.ranging.enabled())
      ranges = std::make_unique<RangeLink>(config.ranging, latest_states_);
    // Everything loaded: apply.
    spdlog::set_level(spdlog::level::from_str(config.log_level));
    if (config.status.socket != old->config.status.socket) {
      status_socket_.reset();
      if (socket) status_socket_ = std::move(socket);
    }
    if (ranging_changed) {
      if (ranges && pipeline_) ranges->attach(&pipeline_->queue);
      ranges_ = std::move(ranges);
      spdlog::info("reload: ranging {}", ranges_ ? "input reopened on port " + std::to_string(ranges_->port()) : "off");
    }
    if (config.web != old->config.web) spdlog::warn("reload: web.* changes take effect when ipsd restarts");
    if (config.outputs != old->config.outputs)
      spdlog::warn(
          "reload: outputs changed: every output is opened anew (sequence numbers restart, subscribers are "
          "dropped until they renew their lease)");
    if (config.cameras == old->config.cameras && config.processing == old->config.processing) {
      runtime_.set(fresh);  // the threads pick it up at their next frame
      if (web_) web_->set_layout(web_layout(*fresh));
      spdlog::info("reload: applied {} (model file {})", config_path_.string(), config.model_file.string());
    } else {
      auto factories = make_factories(config);  // may refuse the new cameras: nothing stopped yet
      spdlog::info("reload: the {} changed, restarting the camera threads",
                   config.cameras != old->config.cameras ? "cameras" : "processing settings");
      stop_pipeline();
      release_free_memory("camera threads restarted");
      start_pipeline(fresh, std::move(factories), false);
    }
  } catch (const ips::InputError& e) {
    spdlog::error("reload refused, keeping the running configuration and model: {}", e.what());
  } catch (const std::exception& e) {
    spdlog::error("reload failed, keeping the running configuration and model: {}", e.what());
  }
  sd_notify(0, "READY=1");
}

void Daemon::tick(std::int64_t now) {
  const std::shared_ptr<const Runtime> rt = runtime_.get();
  Pipeline& p = *pipeline_;
  if (now >= next_sample_ns_) {
    next_sample_ns_ = now + kSampleNs;
    for (int i = 0; i < p.scheduler->cameras(); ++i)
      p.camera_ptrs[static_cast<std::size_t>(i)]->over_budget = p.scheduler->counters(i).over_budget;
    p.rates.sample(p.camera_ptrs, p.names, p.fusion_stats, now);
    sd_notify(0, ("STATUS=" + systemd_status(p.rates)).c_str());
    if (web_) web_->set_status(status_document().dump());
  }
  const double interval = rt->config.status.interval_s;
  if (now >= next_status_log_ns_) {
    // Latency percentiles cover one status interval (10 s when status lines are off).
    next_status_log_ns_ = now + static_cast<std::int64_t>((interval > 0 ? interval : 10.0) * 1e9);
    p.fusion_stats.latency.rotate();
    if (interval > 0)
      for (const auto& line : status_lines(p.rates, p.fusion_stats, p.queue.dropped())) spdlog::info("status {}", line);
  }
  if (now >= next_trim_ns_) {
    next_trim_ns_ = now + kTrimNs;
    release_free_memory("periodic");
  }
  // Watchdog: only if every thread's loop went round recently. A stuck detector or a
  // deadlocked fusion thread therefore gets the daemon restarted by systemd.
  if (watchdog_usec_ > 0 && now >= next_watchdog_ns_) {
    next_watchdog_ns_ = now + static_cast<std::int64_t>(watchdog_usec_) * 1000 / 2;
    const auto limit = static_cast<std::int64_t>(rt->config.stall_timeout_s * 1e9);
    std::string stuck;
    for (std::size_t i = 0; i < p.camera_ptrs.size(); ++i)
      if (now - p.camera_ptrs[i]->heartbeat_ns > limit) stuck += " " + p.names[i];
    if (now - p.fusion_stats.heartbeat_ns > limit) stuck += " fusion";
    for (int k = 0; k < p.workers->count(); ++k)
      if (now - p.workers->heartbeat_ns(k) > limit) stuck += " work:" + std::to_string(k);
    if (stuck.empty()) {
      sd_notify(0, "WATCHDOG=1");
      if (stalled_) spdlog::info("watchdog: every thread is making progress again");
      stalled_ = false;
    } else if (!stalled_) {
      spdlog::error("watchdog: no progress for {:.1f} s in:{}; withholding WATCHDOG=1", rt->config.stall_timeout_s,
                    stuck);
      stalled_ = true;
    }
  }
}

nlohmann::json Daemon::status_document() {
  auto j = status_json(pipeline_->rates, pipeline_->fusion_stats, pipeline_->queue.dropped(), *runtime_.get(),
                       started_ns_, synthetic_epoch_ns_);
  if (web_) j["web"] = web_counters_json(web_->counters());
  if (ranges_) j["ranging"] = ranges_->status();
  // Per camera: its own view of each fixed marker (docs/survey.md, bumped camera).
  for (auto& c : j["cameras"]) c["fixed_markers"] = nlohmann::json::array();
  for (const auto& r : pipeline_->fixed.readings(ips::monotonic_ns()))
    if (r.camera_index >= 0 && static_cast<std::size_t>(r.camera_index) < j["cameras"].size())
      j["cameras"][static_cast<std::size_t>(r.camera_index)]["fixed_markers"].push_back(
          {{"id", r.id}, {"error_m", r.error_m}, {"samples", r.samples}, {"seen", r.seen}, {"moved", r.moved}});
  return j;
}

int Daemon::run() {
  // SIGTERM/SIGINT/SIGHUP arrive here through a signalfd; main() blocked them before the
  // constructor started any thread (outputs start theirs: DDS, subscriptions), see signals.h.
  const int sfd = open_daemon_signalfd();

  started_ns_ = ips::monotonic_ns();
  synthetic_epoch_ns_ = started_ns_;
  if (const auto& w = runtime_.get()->config.web; !w.listen.empty()) {
    try {
      web_ = std::make_unique<ips::WebServer>(w, runtime_.get()->config.markers.dictionary);
    } catch (...) {
      ::close(sfd);
      throw;
    }
  }
  if (!start_pipeline(runtime_.get(), make_factories(runtime_.get()->config), true)) {
    ::close(sfd);
    return 1;
  }
  {
    const auto rt = runtime_.get();
    bool synthetic = false;
    for (const auto& c : rt->config.cameras) synthetic = synthetic || c.source == ips::SourceKind::kSynthetic;
    if (synthetic) spdlog::info("synthetic cameras: scene time 0 = CLOCK_MONOTONIC {} ns", synthetic_epoch_ns_);
    spdlog::info("ipsd {} running: {} camera(s), fusion '{}', {} output(s)", IPS_VERSION, rt->config.cameras.size(),
                 rt->config.fusion.method, rt->config.outputs.size());
    // bodies: published as body records, stream version 2 (docs/bodies.md).
    if (!rt->config.bodies.empty())
      spdlog::info(
          "bodies: {} configured; the stream is protocol version 2 (body records; their markers are not "
          "published as plain markers)",
          rt->config.bodies.size());
  }
  if (sd_watchdog_enabled(0, &watchdog_usec_) <= 0) watchdog_usec_ = 0;
  sd_notify(0, "READY=1\nSTATUS=running");
  next_sample_ns_ = started_ns_ + kSampleNs;
  next_trim_ns_ = started_ns_ + kTrimNs;
  next_status_log_ns_ =
      started_ns_ +
      static_cast<std::int64_t>(
          (runtime_.get()->config.status.interval_s > 0 ? runtime_.get()->config.status.interval_s : 10.0) * 1e9);

  bool running = true;
  while (running) {
    pollfd fds[2] = {{sfd, POLLIN, 0}, {status_socket_ ? status_socket_->fd() : -1, POLLIN, 0}};
    const int rc = ::poll(fds, 2, kPollMs);
    if (rc < 0 && errno != EINTR) throw std::runtime_error(std::string("poll: ") + std::strerror(errno));
    if (rc > 0 && (fds[0].revents & POLLIN)) {
      signalfd_siginfo info{};
      while (::read(sfd, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
        if (info.ssi_signo == SIGHUP) {
          spdlog::info("SIGHUP: reloading {}", config_path_.string());
          reload();
        } else {
          spdlog::info("{}: stopping", strsignal(static_cast<int>(info.ssi_signo)));
          running = false;
        }
      }
    }
    const std::int64_t now = ips::monotonic_ns();
    if (rc > 0 && status_socket_ && (fds[1].revents & POLLIN)) {
      pipeline_->rates.sample(pipeline_->camera_ptrs, pipeline_->names, pipeline_->fusion_stats, now);
      next_sample_ns_ = now + kSampleNs;
      const auto j = status_document();
      status_socket_->serve(j.dump() + "\n");
      if (web_) web_->set_status(j.dump());
    }
    if (running) tick(now);
  }
  sd_notify(0, "STOPPING=1");
  stop_pipeline();
  web_.reset();
  ::close(sfd);
  spdlog::info("stopped");
  return 0;
}

}  // namespace ipsd
