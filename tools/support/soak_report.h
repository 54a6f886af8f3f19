// bench_soak's figures and their two forms: OUT/summary.json (machine-readable) and
// OUT/summary.txt (tables for docs/reliability.md), plus OUT/samples.csv (every 10 s sample).
// Header-only; used by tools/bench_soak.cpp only.
#pragma once

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "soak_faults.h"
#include "soak_monitor.h"

namespace ips::soak {

struct Fault {
  std::string kind, detail, check;
  std::int64_t start_ns = 0, end_ns = 0;
  std::vector<bool> excused;  ///< cameras whose silence is expected until they are back
  std::size_t probe = 0;
  std::int64_t recovered_ns = 0;  ///< every camera published a record captured after end_ns (0 = never)
};

struct Sample {
  std::int64_t t_ns = 0;
  ProcSample proc;
  double load = NAN;
  std::uint64_t datagrams = 0;
  /// From the daemon's status, accumulated over camera restarts (which reset the daemon's
  /// counters): frames the emulated driver dropped because the daemon had no buffer queued
  /// (it did not keep up: CPU starvation), per camera and summed; corrupt frames counted.
  std::vector<std::uint64_t> camera_drops;
  std::uint64_t drops = 0, corrupt = 0;
};

class Report {
 public:
  Report(double seconds, double fps, double period, double gap_s, double watchdog_s, int cameras)
      : seconds_(seconds), fps_(fps), period_(period), gap_s_(gap_s), watchdog_s_(watchdog_s), cameras_(cameras) {}

  void start(std::int64_t t0) { t0_ = t0; }
  void add_sample(const Sample& s) {
    std::lock_guard lock(mutex_);
    samples_.push_back(s);
  }
  void add_fault(const Fault& f) { faults_.push_back(f); }
  const std::vector<Fault>& faults() const { return faults_; }
  /// The niceness asked for (bench_soak --nice) and the one ipsd had (nullopt: unknown).
  void set_nice(int asked, std::optional<int> actual) { nice_asked_ = asked, nice_actual_ = actual; }
  void set_recovery(std::size_t i, const RecoveryProbe& p) { faults_[i].recovered_ns = p.recovered_ns(); }

  void finish(std::int64_t t_end, bool died, std::optional<int> exit_status, const StreamMonitor::Totals& totals,
              const std::vector<Gap>& gaps, const NotifyListener::Figures& notify, const nlohmann::json& final_status,
              int sanitizer_lines) {
    t_end_ = t_end;
    died_ = died;
    exit_status_ = exit_status;
    totals_ = totals;
    notify_ = notify;
    final_status_ = final_status;
    sanitizer_lines_ = sanitizer_lines;
    for (const auto& g : gaps) {
      GapRow row{g, "", false, load_at(g.to_ns), drops_between(g.camera, g.from_ns, g.to_ns)};
      // The fault under way (or the last one before) names the context of any gap.
      for (const auto& f : faults_) {
        const std::int64_t until = f.recovered_ns ? f.recovered_ns : t_end_;
        if (f.start_ns <= g.to_ns) row.context = f.kind + " " + f.detail;
        if (g.from_ns < until && g.to_ns > f.start_ns && f.excused[static_cast<std::size_t>(g.camera)])
          row.excused = true;
      }
      gaps_.push_back(row);
    }
  }

  bool passed() const {
    bool ok = !died_ && exit_status_ == std::optional<int>(0) && unexcused_gaps() == 0 && notify_.missed == 0 &&
              notify_.pings > 0 && sanitizer_lines_ == 0;
    for (const auto& f : faults_) ok = ok && f.recovered_ns != 0 && f.check.find("NO") == std::string::npos;
    return ok && memory_flat().value_or(true);
  }

  // "Flat after warm-up", judged on runs of 30 minutes or more (a shorter trend is mostly the
  // once-a-minute trim cycle): the least-squares trend after warm-up at most kMaxMemoryTrend.
  // 10 MiB/h still allows 7 GiB in a month: a run that passes it is flat within what an hour
  // can measure, not proof of months. nullopt = not judged.
  static constexpr double kMaxMemoryTrend = 10.0;  // MiB/h
  std::optional<bool> memory_flat() const {
    const Memory m = memory();
    if (seconds_ < 1800 || std::isnan(m.slope)) return std::nullopt;
    return m.slope <= kMaxMemoryTrend;
  }

  void write(const std::filesystem::path& out) const {
    std::ofstream(out / "summary.json") << json().dump(1) << "\n";
    std::ofstream(out / "summary.txt") << text();
    std::ofstream csv(out / "samples.csv");
    csv << "t_s,rss_kib,threads,fds,load1,datagrams,ipsd_cpu_pct,drops,corrupt\n";
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const auto& s = samples_[i];
      csv << rel(s.t_ns) << ',' << s.proc.rss_kib << ',' << s.proc.threads << ',' << s.proc.fds << ',' << s.load << ','
          << s.datagrams << ',' << cpu_pct(i) << ',' << s.drops << ',' << s.corrupt << '\n';
    }
  }

  nlohmann::json json() const {
    using nlohmann::json;
    json j;
    j["parameters"] = {{"seconds", seconds_},
                       {"fps", fps_},
                       {"fault_period_s", period_},
                       {"gap_threshold_s", gap_s_},
                       {"watchdog_usec", static_cast<long long>(watchdog_s_ * 1e6)},
                       {"cameras", cameras_},
                       {"nice_asked", nice_asked_},
                       {"ipsd_nice", nice_actual_ ? json(*nice_actual_) : json(nullptr)}};
    j["measured_s"] = 1e-9 * static_cast<double>(t_end_ - t0_);
    j["passed"] = passed();
    j["crashes"] = died_ ? 1 : 0;
    j["exit_status"] = exit_status_ ? json(*exit_status_) : json(nullptr);
    j["sanitizer_lines"] = sanitizer_lines_;
    if (!samples_.empty()) {
      const auto& a = samples_.front();
      const auto& b = samples_.back();
      j["threads"] = {{"start", a.proc.threads}, {"end", b.proc.threads}};
      j["fds"] = {{"start", a.proc.fds}, {"end", b.proc.fds}};
    }
    const Memory m = memory();
    j["memory"] = {{"warmup_s", m.warmup_s},
                   {"rss_mib_after_warmup", m.first},
                   {"rss_mib_end", m.last},
                   {"rss_mib_min_after_warmup", m.min},
                   {"rss_mib_max_after_warmup", m.max},
                   {"slope_mib_per_hour", m.slope},
                   {"max_slope_mib_per_hour", kMaxMemoryTrend},
                   {"flat", memory_flat() ? json(*memory_flat()) : json(nullptr)}};
    j["per_minute"] = json::array();
    for (const std::size_t i : per_minute()) {
      const Sample& s = samples_[i];
      j["per_minute"].push_back({{"t_s", rel(s.t_ns)},
                                 {"rss_mib", s.proc.rss_kib / 1024.0},
                                 {"threads", s.proc.threads},
                                 {"fds", s.proc.fds},
                                 {"load1", s.load},
                                 {"ipsd_cpu_pct", cpu_pct(i)},
                                 {"driver_drops", s.drops},
                                 {"corrupt_frames", s.corrupt}});
    }
    j["stream"] = {{"datagrams", totals_.datagrams},
                   {"malformed", totals_.malformed},
                   {"datagrams_lost", totals_.sequence_lost},
                   {"sequence_restarts", totals_.sequence_back},
                   {"records_per_camera", totals_.records},
                   {"widest_silence_s", 1e-9 * static_cast<double>(totals_.widest_silence_ns)}};
    j["gaps"] = json::array();
    for (const auto& g : gaps_)
      j["gaps"].push_back({{"camera", g.gap.camera},
                           {"at_s", rel(g.gap.from_ns)},
                           {"length_s", 1e-9 * static_cast<double>(g.gap.to_ns - g.gap.from_ns)},
                           {"excused", g.excused},
                           {"during", g.context},
                           {"load1", g.load},
                           {"camera_driver_drops_around", g.drops}});
    j["unexcused_gaps"] = unexcused_gaps();
    j["unexcused_gaps_with_driver_drops"] =
        std::count_if(gaps_.begin(), gaps_.end(), [](const GapRow& g) { return !g.excused && g.drops > 0; });
    j["watchdog"] = {{"pings", notify_.pings},
                     {"missed", notify_.missed},
                     {"widest_interval_s", 1e-9 * static_cast<double>(notify_.widest_ping_interval_ns)},
                     {"ready", notify_.ready},
                     {"reloading", notify_.reloading},
                     {"stopping", notify_.stopping}};
    j["faults"] = json::array();
    for (const auto& f : faults_)
      j["faults"].push_back(
          {{"at_s", rel(f.start_ns)},
           {"kind", f.kind},
           {"detail", f.detail},
           {"check", f.check},
           {"recovery_s", f.recovered_ns ? json(1e-9 * static_cast<double>(f.recovered_ns - f.end_ns)) : json(nullptr)},
           {"load1", load_at(f.start_ns)}});
    j["final_status"] = final_status_;
    return j;
  }

  std::string text() const {
    std::string t;
    char line[512];
    auto add = [&](const char* fmt, auto... args) {
      std::snprintf(line, sizeof line, fmt, args...);
      t += line;
    };
    add("\nbench_soak: %.0f s measured, 3 emulated V4L2 cameras at %.0f fps, a fault every %.0f s; %s\n",
        1e-9 * static_cast<double>(t_end_ - t0_), fps_, period_, passed() ? "PASSED" : "FAILED");
    double lmin = 1e9, lmax = 0, lsum = 0;
    for (const auto& s : samples_) lmin = std::min(lmin, s.load), lmax = std::max(lmax, s.load), lsum += s.load;
    add("load average (1 min) over the run: min %.2f, mean %.2f, max %.2f (2 cores, shared)\n", lmin,
        samples_.empty() ? 0.0 : lsum / static_cast<double>(samples_.size()), lmax);
    add("ipsd niceness: %s (asked %d)\n", nice_actual_ ? std::to_string(*nice_actual_).c_str() : "unknown",
        nice_asked_);
    add("crashes: %d; exit status after SIGTERM: %s; sanitizer reports: %d\n", died_ ? 1 : 0,
        exit_status_ ? std::to_string(*exit_status_).c_str() : "none (still running)", sanitizer_lines_);
    if (!samples_.empty())
      add("threads start/end: %d / %d; fds start/end: %d / %d\n", samples_.front().proc.threads,
          samples_.back().proc.threads, samples_.front().proc.fds, samples_.back().proc.fds);
    const Memory m = memory();
    add("resident memory after %.0f s warm-up: %.1f MiB, end %.1f MiB, range %.1f-%.1f MiB, trend %+.2f MiB/h: %s\n",
        m.warmup_s, m.first, m.last, m.min, m.max, m.slope,
        !memory_flat()   ? "not judged (run < 30 min)"
        : *memory_flat() ? "flat (<= 10 MiB/h)"
                         : "NOT FLAT (> 10 MiB/h)");
    add("watchdog (WATCHDOG_USEC %.0f s): %llu pings, widest interval %.2f s, missed %llu\n", watchdog_s_,
        static_cast<unsigned long long>(notify_.pings), 1e-9 * static_cast<double>(notify_.widest_ping_interval_ns),
        static_cast<unsigned long long>(notify_.missed));
    add("stream: %llu datagrams, %llu lost (sequence), %llu malformed, widest silence of the whole stream %.2f s\n",
        static_cast<unsigned long long>(totals_.datagrams), static_cast<unsigned long long>(totals_.sequence_lost),
        static_cast<unsigned long long>(totals_.malformed), 1e-9 * static_cast<double>(totals_.widest_silence_ns));
    const int starved = static_cast<int>(
        std::count_if(gaps_.begin(), gaps_.end(), [](const GapRow& g) { return !g.excused && g.drops > 0; }));
    add("camera silences > %.1f s: %d excused (camera unplugged / restarting), %d NOT excused, of which %d with that\n"
        "camera's driver drops around them (frames lost because the daemon had no buffer queued: it did not get the "
        "CPU)\n",
        gap_s_, static_cast<int>(gaps_.size()) - unexcused_gaps(), unexcused_gaps(), starved);
    t += "\n| minute | resident MiB | threads | fds | load (1 min) | ipsd CPU % (last 10 s) | driver drops (total) "
         "|\n|---|---|---|---|---|---|---|\n";
    for (const std::size_t i : per_minute()) {
      const Sample& s = samples_[i];
      add("| %.0f | %.1f | %d | %d | %.2f | %.0f | %llu |\n", rel(s.t_ns) / 60.0, s.proc.rss_kib / 1024.0,
          s.proc.threads, s.proc.fds, s.load, cpu_pct(i), static_cast<unsigned long long>(s.drops));
    }
    t += "\n| fault | count | recovery median / max (s) | checks failed |\n|---|---|---|---|\n";
    for (const std::string kind : {"unplug", "corrupt", "hup-good", "hup-bad", "hup-cams", "garbage", "listener"}) {
      std::vector<double> r;
      int n = 0, failed = 0, never = 0;
      for (const auto& f : faults_) {
        if (f.kind != kind) continue;
        ++n;
        failed += f.check.find("NO") != std::string::npos;
        if (f.recovered_ns)
          r.push_back(1e-9 * static_cast<double>(f.recovered_ns - f.end_ns));
        else
          ++never;
      }
      if (n == 0) continue;
      std::sort(r.begin(), r.end());
      add("| %s | %d | %.2f / %.2f%s | %d |\n", kind.c_str(), n, r.empty() ? NAN : r[r.size() / 2],
          r.empty() ? NAN : r.back(), never ? (" (" + std::to_string(never) + " never)").c_str() : "", failed);
    }
    t += "\nrecovery = from the end of the fault (replug, SIGHUP, burst end...) to the first record of every camera "
         "captured after it\n";
    t += "\nevery fault:\n";
    for (const auto& f : faults_)
      add("  %7.1f s  %-9s %-60s recovery %6.2f s  load %.2f  %s\n", rel(f.start_ns), f.kind.c_str(), f.detail.c_str(),
          f.recovered_ns ? 1e-9 * static_cast<double>(f.recovered_ns - f.end_ns) : NAN, load_at(f.start_ns),
          f.check.c_str());
    if (!gaps_.empty()) t += "\ncamera silences:\n";
    for (const auto& g : gaps_)
      add("  %7.1f s  camera %d silent %.2f s  %s  load %.2f  its driver drops in the samples around it %llu  "
          "(during/after: %s)\n",
          rel(g.gap.from_ns), g.gap.camera, 1e-9 * static_cast<double>(g.gap.to_ns - g.gap.from_ns),
          g.excused ? "excused" : "NOT EXCUSED", g.load, static_cast<unsigned long long>(g.drops), g.context.c_str());
    return t;
  }

 private:
  struct GapRow {
    Gap gap;
    std::string context;
    bool excused = false;
    double load = NAN;
    std::uint64_t drops = 0;  ///< driver drops (all cameras) in the 10-s samples spanning the gap
  };
  struct Memory {
    double warmup_s = 0, first = NAN, last = NAN, min = NAN, max = NAN, slope = NAN;
  };

  double rel(std::int64_t t) const { return 1e-9 * static_cast<double>(t - t0_); }
  // ipsd's CPU use (% of one core) over the interval ending at sample i.
  double cpu_pct(std::size_t i) const {
    if (i == 0 || samples_[i].proc.cpu_ticks < 0 || samples_[i - 1].proc.cpu_ticks < 0) return NAN;
    const double dt = 1e-9 * static_cast<double>(samples_[i].t_ns - samples_[i - 1].t_ns);
    return dt > 0 ? 100.0 * static_cast<double>(samples_[i].proc.cpu_ticks - samples_[i - 1].proc.cpu_ticks) /
                        static_cast<double>(::sysconf(_SC_CLK_TCK)) / dt
                  : NAN;
  }
  // Camera c's driver drops (the daemon not keeping up) in the 10-s samples around [from, to].
  std::uint64_t drops_between(int c, std::int64_t from, std::int64_t to) const {
    const auto k = static_cast<std::size_t>(c);
    auto of = [&](const Sample& s) { return k < s.camera_drops.size() ? s.camera_drops[k] : 0; };
    std::uint64_t before = 0, after = 0;
    for (const auto& s : samples_) {
      if (s.t_ns <= from) before = of(s);
      after = of(s);
      if (s.t_ns >= to) break;
    }
    return after >= before ? after - before : 0;
  }
  int unexcused_gaps() const {
    return static_cast<int>(std::count_if(gaps_.begin(), gaps_.end(), [](const GapRow& g) { return !g.excused; }));
  }
  double load_at(std::int64_t t) const {
    double best = NAN;
    std::int64_t dist = INT64_MAX;
    for (const auto& s : samples_)
      if (std::llabs(s.t_ns - t) < dist) dist = std::llabs(s.t_ns - t), best = s.load;
    return best;
  }
  // Indices of one sample a minute (and the last).
  std::vector<std::size_t> per_minute() const {
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < samples_.size(); ++i)
      if (out.empty() || samples_[i].t_ns - samples_[out.back()].t_ns >= 59'000'000'000LL || i + 1 == samples_.size())
        out.push_back(i);
    return out;
  }
  // Warm-up: the first 5 minutes (a quarter of a short run). The trend is a least-squares
  // line through every sample after it.
  Memory memory() const {
    Memory m;
    m.warmup_s = std::min(300.0, seconds_ / 4);
    double n = 0, st = 0, sr = 0, stt = 0, str = 0;
    for (const auto& s : samples_) {
      if (rel(s.t_ns) < m.warmup_s || std::isnan(s.proc.rss_kib)) continue;
      const double t = rel(s.t_ns) / 3600.0, r = s.proc.rss_kib / 1024.0;
      if (std::isnan(m.first)) m.first = r, m.min = r, m.max = r;
      m.last = r;
      m.min = std::min(m.min, r);
      m.max = std::max(m.max, r);
      n += 1, st += t, sr += r, stt += t * t, str += t * r;
    }
    if (n >= 2 && n * stt - st * st > 0) m.slope = (n * str - st * sr) / (n * stt - st * st);
    return m;
  }

  double seconds_, fps_, period_, gap_s_, watchdog_s_;
  int cameras_;
  int nice_asked_ = 0;
  std::optional<int> nice_actual_;
  std::int64_t t0_ = 0, t_end_ = 0;
  mutable std::mutex mutex_;
  std::vector<Sample> samples_;
  std::vector<Fault> faults_;
  std::vector<GapRow> gaps_;
  bool died_ = false;
  std::optional<int> exit_status_;
  StreamMonitor::Totals totals_;
  NotifyListener::Figures notify_;
  nlohmann::json final_status_;
  int sanitizer_lines_ = 0;
};

}  // namespace ips::soak
