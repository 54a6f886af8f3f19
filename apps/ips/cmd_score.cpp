// `ips score`: a trajectory scored against ground truth (a motion-capture export, a surveyed
// path, the simulator's truth.csv): for every estimate, the truth at its time (linearly
// interpolated between the two truth rows around it); RMSE in 2-D, 3-D and heading; the
// detection ratio (the truth instants with an estimate within --timeout); per object (a
// marker id or a body's name); an optional plot of the 2-D error over time. The estimates are
// a CSV (ips localise's poses.csv) or ipsd's stream as recorded by `ips listen --record`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command.h"
#include "ips/core/csv_fields.h"
#include "ips/core/error.h"
#include "ips/output/packet_codec.h"

namespace cmd_score {  // named, not anonymous: unique in a unity build

struct Args {
  std::string estimate, stream, truth, plot;
  double timeout_s = 0.5;
};

// Objects in the order people expect: marker ids by number, then bodies by name.
struct ById {
  static bool numeric(const std::string& s) {
    return !s.empty() && s.size() < 19 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  }
  bool operator()(const std::string& a, const std::string& b) const {
    if (numeric(a) != numeric(b)) return numeric(a);
    if (numeric(a)) return std::stoll(a) < std::stoll(b);
    return a < b;
  }
};

struct Sample {
  long long t_ns = 0;
  double x = 0, y = 0, z = NAN, yaw = NAN;
};

using Tracks = std::map<std::string, std::vector<Sample>, ById>;

// id -> samples in time order. Columns by name: t_ns, x, y required; z, yaw, id optional
// (no id column: one object, id 0; an id is a marker's number or a body's name); any other
// column is ignored.
Tracks read_track(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ips::InputError(path + ": cannot open");
  std::string line;
  if (!std::getline(in, line)) throw ips::InputError(path + ": empty (expected a header t_ns,x,y[,z][,yaw][,id])");
  std::map<std::string, std::size_t> col;
  const auto header = ips::split_csv_line(line);
  for (std::size_t i = 0; i < header.size(); ++i) col[std::string(header[i])] = i;
  for (const char* need : {"t_ns", "x", "y"}) {
    if (!col.count(need)) {
      throw ips::InputError(path + ":1: no column '" + need + "' (expected a header t_ns,x,y[,z][,yaw][,id])");
    }
  }
  auto opt = [&](const char* name) -> std::optional<std::size_t> {
    const auto it = col.find(name);
    return it == col.end() ? std::nullopt : std::optional<std::size_t>(it->second);
  };
  const auto z = opt("z"), yaw = opt("yaw"), id = opt("id");
  Tracks out;
  for (int n = 2; std::getline(in, line); ++n) {
    if (ips::trim_csv_field(line).empty()) continue;
    const auto f = ips::split_csv_line(line);
    const std::string at = path + ":" + std::to_string(n);
    if (f.size() < header.size())
      throw ips::InputError(at + ": " + std::to_string(f.size()) + " fields, the header has " +
                            std::to_string(header.size()));
    auto whole = [&](std::size_t c, const char* name) {
      const std::string text(f[c]);
      try {
        std::size_t used = 0;
        const long long v = std::stoll(text, &used);
        if (used != text.size()) throw std::invalid_argument(name);
        return v;
      } catch (const std::exception&) {
        throw ips::InputError(at + ": column '" + name + "': '" + text + "' is not a whole number");
      }
    };
    Sample s;
    s.t_ns = whole(col["t_ns"], "t_ns");
    s.x = ips::parse_csv_number(f[col["x"]], at, "column 'x'");
    s.y = ips::parse_csv_number(f[col["y"]], at, "column 'y'");
    if (z) s.z = ips::parse_csv_number(f[*z], at, "column 'z'");
    if (yaw) s.yaw = ips::parse_csv_number(f[*yaw], at, "column 'yaw'");
    const std::string object = id ? std::string(ips::trim_csv_field(f[*id])) : "0";
    if (object.empty()) throw ips::InputError(at + ": column 'id' is empty");
    auto& track = out[object];
    if (!track.empty() && s.t_ns <= track.back().t_ns) {
      throw ips::InputError(at + ": t_ns not after the previous row's of the same id (rows must be in time order)");
    }
    track.push_back(s);
  }
  if (out.empty()) throw ips::InputError(path + ": no rows");
  return out;
}

// ipsd's stream as `ips listen --record` writes it: one datagram per line in the stream's JSON
// form. Each marker record at its capture time (the datagram's realtime + the record's dt) under
// its id, each body's under its name; a heading only where the record measured it. A record
// not after its object's previous one (the same update sent twice) is skipped and counted.
Tracks read_stream(const std::string& path, long& repeated) {
  std::ifstream in(path);
  if (!in) throw ips::InputError(path + ": cannot open");
  Tracks out;
  std::string line;
  auto add = [&](const std::string& object, long long t, Sample s) {
    auto& track = out[object];
    s.t_ns = t;
    if (!track.empty() && t <= track.back().t_ns) {
      ++repeated;
      return;
    }
    track.push_back(s);
  };
  for (int n = 1; std::getline(in, line); ++n) {
    if (ips::trim_csv_field(line).empty()) continue;
    ips::Datagram d;
    try {
      d = ips::decode_datagram(std::span(reinterpret_cast<const std::uint8_t*>(line.data()), line.size()));
    } catch (const ips::InputError& e) {
      throw ips::InputError(path + ":" + std::to_string(n) + ": not a datagram of the stream's JSON form (" + e.what() +
                            ")");
    }
    for (const auto& m : d.markers)
      add(std::to_string(m.id), d.capture_realtime_ns + 1000LL * m.dt_us, {0, m.x, m.y, m.z, m.has_yaw ? m.yaw : NAN});
    for (const auto& b : d.bodies)
      add(b.name, d.capture_realtime_ns + 1000LL * b.dt_us, {0, b.x, b.y, b.z, b.has_yaw ? b.yaw : NAN});
  }
  if (out.empty()) throw ips::InputError(path + ": no marker or body records");
  return out;
}

// The truth at time t: interpolated between the rows around it, or the nearest row within
// `timeout` of t beyond either end; nullopt when no row is that close.
std::optional<Sample> truth_at(const std::vector<Sample>& truth, long long t, long long timeout_ns) {
  const auto after =
      std::lower_bound(truth.begin(), truth.end(), t, [](const Sample& s, long long v) { return s.t_ns < v; });
  if (after != truth.end() && after->t_ns == t) return *after;
  if (after == truth.begin() || after == truth.end()) {
    const Sample& near = after == truth.end() ? truth.back() : truth.front();
    return std::llabs(near.t_ns - t) <= timeout_ns ? std::optional<Sample>(near) : std::nullopt;
  }
  const Sample& a = *(after - 1);
  const Sample& b = *after;
  // A gap in the truth longer than twice the timeout is a time it was not measured.
  if (b.t_ns - a.t_ns > 2 * timeout_ns && std::min(t - a.t_ns, b.t_ns - t) > timeout_ns) return std::nullopt;
  const double w = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  Sample s;
  s.t_ns = t;
  s.x = a.x + w * (b.x - a.x);
  s.y = a.y + w * (b.y - a.y);
  s.z = a.z + w * (b.z - a.z);
  s.yaw = a.yaw + w * std::remainder(b.yaw - a.yaw, 2 * M_PI);
  return s;
}

struct Score {
  long estimates = 0, matched = 0, truth_rows = 0, detected = 0;
  double sum2d = 0, sum3d = 0, sum_yaw = 0, max2d = 0;
  long n3d = 0, n_yaw = 0;
  std::vector<double> e2d;
  std::vector<std::pair<double, double>> series;  // (seconds since the first truth row, 2-D error m)
};

Score score(const std::vector<Sample>& est, const std::vector<Sample>& truth, long long timeout_ns) {
  Score s;
  s.estimates = static_cast<long>(est.size());
  s.truth_rows = static_cast<long>(truth.size());
  for (const Sample& e : est) {
    const auto t = truth_at(truth, e.t_ns, timeout_ns);
    if (!t) continue;
    ++s.matched;
    const double d2 = std::hypot(e.x - t->x, e.y - t->y);
    s.sum2d += d2 * d2;
    s.max2d = std::max(s.max2d, d2);
    s.e2d.push_back(d2);
    s.series.emplace_back(static_cast<double>(e.t_ns - truth.front().t_ns) * 1e-9, d2);
    if (std::isfinite(e.z) && std::isfinite(t->z)) {
      s.sum3d += d2 * d2 + (e.z - t->z) * (e.z - t->z);
      ++s.n3d;
    }
    if (std::isfinite(e.yaw) && std::isfinite(t->yaw)) {
      const double dy = std::remainder(e.yaw - t->yaw, 2 * M_PI);
      s.sum_yaw += dy * dy;
      ++s.n_yaw;
    }
  }
  // Detection ratio: truth instants with an estimate within the timeout.
  for (const Sample& t : truth) {
    const auto it =
        std::lower_bound(est.begin(), est.end(), t.t_ns, [](const Sample& s2, long long v) { return s2.t_ns < v; });
    const bool near_after = it != est.end() && it->t_ns - t.t_ns <= timeout_ns;
    const bool near_before = it != est.begin() && t.t_ns - (it - 1)->t_ns <= timeout_ns;
    s.detected += near_after || near_before;
  }
  std::sort(s.e2d.begin(), s.e2d.end());
  return s;
}

void write_plot(const std::map<std::string, Score, ById>& scores, const std::string& path) {
  const int W = 1000, H = 420, left = 70, right = 40, top = 30, bottom = 50;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  double t_max = 1e-9, e_max = 1e-9;
  for (const auto& [id, s] : scores) {
    for (const auto& [t, e] : s.series) {
      t_max = std::max(t_max, t);
      e_max = std::max(e_max, e);
    }
  }
  e_max *= 1.1;
  const double mm = e_max * 1000;
  auto px = [&](double t, double e) {
    return cv::Point(left + static_cast<int>((W - left - right) * t / t_max),
                     H - bottom - static_cast<int>((H - top - bottom) * e / e_max));
  };
  cv::rectangle(img, px(0, e_max), px(t_max, 0), cv::Scalar(0, 0, 0));
  for (int k = 0; k <= 4; ++k) {
    char label[32];
    std::snprintf(label, sizeof label, "%.3g", mm * k / 4);
    cv::putText(img, label, px(0, e_max * k / 4) + cv::Point(-62, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
    std::snprintf(label, sizeof label, "%.3g s", t_max * k / 4);
    cv::putText(img, label, px(t_max * k / 4, 0) + cv::Point(-15, 20), cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
  }
  cv::putText(img, "2-D error (mm) against the truth at each estimate's time", {left, 20}, cv::FONT_HERSHEY_SIMPLEX,
              0.5, {0, 0, 0});
  const cv::Scalar colours[] = {{200, 80, 0}, {0, 120, 220}, {40, 160, 40}, {160, 0, 160}, {0, 0, 200}};
  int k = 0;
  for (const auto& [id, s] : scores) {
    const cv::Scalar c = colours[k % 5];
    std::vector<cv::Point> pts;
    for (const auto& [t, e] : s.series) pts.push_back(px(t, e));
    if (pts.size() > 1) cv::polylines(img, pts, false, c, 1, cv::LINE_AA);
    for (const auto& p : pts) cv::circle(img, p, 2, c, cv::FILLED);
    cv::putText(img, (ById::numeric(id) ? "id " : "") + id, {W - right - 110, top + 18 * (k + 1)},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, c);
    ++k;
  }
  if (!cv::imwrite(path, img)) throw ips::InputError(path + ": cannot write the plot");
}

int run(const Args& a) {
  if (!(a.timeout_s > 0)) throw ips::InputError("--timeout must be > 0 s");
  if (a.estimate.empty() == a.stream.empty()) throw ips::InputError("give one of --estimate CSV or --stream JSONL");
  long repeated = 0;
  const auto est = a.stream.empty() ? read_track(a.estimate) : read_stream(a.stream, repeated);
  if (repeated > 0)
    std::printf("%s: %ld records not after their object's previous one, skipped\n", a.stream.c_str(), repeated);
  const auto truth = read_track(a.truth);
  const auto timeout_ns = static_cast<long long>(std::llround(a.timeout_s * 1e9));
  std::map<std::string, Score, ById> scores;
  for (const auto& [id, t] : truth) {
    const auto e = est.find(id);
    scores[id] = score(e == est.end() ? std::vector<Sample>{} : e->second, t, timeout_ns);
  }
  for (const auto& [id, e] : est) {
    if (!truth.count(id)) std::printf("id %s: %zu estimates, no truth: not scored\n", id.c_str(), e.size());
  }
  std::printf("%6s %9s %9s %10s %12s %12s %12s %12s %12s\n", "id", "estimates", "matched", "detection", "RMSE 2-D",
              "p95 2-D", "max 2-D", "RMSE 3-D", "RMSE yaw");
  for (const auto& [id, s] : scores) {
    auto mm = [](double m) {
      char b[32];
      std::snprintf(b, sizeof b, "%.2f mm", m * 1000);
      return std::string(b);
    };
    const std::string rmse2 = s.matched ? mm(std::sqrt(s.sum2d / static_cast<double>(s.matched))) : "-";
    const std::string p95 = s.matched ? mm(s.e2d[static_cast<std::size_t>(0.95 * (s.e2d.size() - 1) + 0.5)]) : "-";
    const std::string mx = s.matched ? mm(s.max2d) : "-";
    const std::string rmse3 = s.n3d ? mm(std::sqrt(s.sum3d / static_cast<double>(s.n3d))) : "-";
    char yaw[32] = "-";
    if (s.n_yaw)
      std::snprintf(yaw, sizeof yaw, "%.3f deg", std::sqrt(s.sum_yaw / static_cast<double>(s.n_yaw)) * 180 / M_PI);
    std::printf("%6s %9ld %9ld %9.1f%% %12s %12s %12s %12s %12s\n", id.c_str(), s.estimates, s.matched,
                100.0 * static_cast<double>(s.detected) / static_cast<double>(s.truth_rows), rmse2.c_str(), p95.c_str(),
                mx.c_str(), rmse3.c_str(), yaw);
  }
  std::printf(
      "detection: truth rows with an estimate within %.3g s; errors: each estimate against the truth "
      "interpolated at its time\n",
      a.timeout_s);
  if (!a.plot.empty()) {
    write_plot(scores, a.plot);
    std::printf("wrote %s\n", a.plot.c_str());
  }
  return 0;
}

IPS_REGISTER_COMMAND(
    "score", "Score a trajectory against ground truth: RMSE at each estimate's time, detection ratio",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      auto* estimate =
          sub.add_option("--estimate", a->estimate, "CSV with t_ns,x,y[,z][,yaw][,id] (e.g. ips localise's poses.csv)");
      sub.add_option("--stream", a->stream,
                     "ipsd's stream recorded by `ips listen --record FILE` (JSON lines; capture times on the "
                     "realtime clock)")
          ->excludes(estimate);
      sub.add_option("--truth", a->truth,
                     "CSV with t_ns,x,y[,z][,yaw][,id], the same clock (id: a marker's number or a body's name)")
          ->required();
      sub.add_option("--timeout", a->timeout_s, "An estimate this close (s) to a truth instant detects it")
          ->capture_default_str();
      sub.add_option("--plot", a->plot, "Write a PNG of the 2-D error over time");
      return [a] { return run(*a); };
    });

}  // namespace cmd_score
