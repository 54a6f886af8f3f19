// `ips status`: ask a running ipsd for its status over its unix socket (status.socket in the
// daemon's configuration) and print it, per camera.
#include <grp.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <utility>

#include <spdlog/fmt/fmt.h>
#include <nlohmann/json.hpp>

#include "command.h"
#include "ips/core/error.h"

namespace cmd_status {  // named, not anonymous: unique in a unity build

struct StatusOptions {
  std::string socket = "/run/ipsd/status.sock";
  bool json = false;
};

/// What to do about a failed connect, for the error message.
std::string why_not_connected(const std::string& path, int err) {
  if (err != EACCES) return " (is ipsd running, with status.socket set?)";
  // The daemon makes its socket 0660 for its group (ipsd under systemd): name that group.
  std::string name = "ipsd";
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0)
    if (const struct group* g = ::getgrgid(st.st_gid)) name = g->gr_name;
  return " (the status socket is for its owner and group " + name + ": add yourself with `sudo usermod -aG " + name +
         " $USER` and log in again, or run ips status with sudo)";
}

std::string fetch(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) throw ips::InputError("--socket: path too long: " + path);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  timeval tv{2, 0};  // a daemon that does not answer within 2 s is reported, not waited for
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error("cannot connect to " + path + ": " + std::strerror(err) + why_not_connected(path, err));
  }
  std::string text;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fd, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  return text;
}

int run_status(const StatusOptions& o) {
  const std::string text = fetch(o.socket);
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object() || j.value("type", "") != "ipsd.status")
    throw std::runtime_error(o.socket + ": the answer is not an ipsd status document");
  if (o.json) {
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("ipsd %s, pid %ld, config %s, fusion %s: %.1f updates/s, latency %.1f ms, %llu updates\n",
              j.value("version", "?").c_str(), j.value("pid", 0L), j.value("config", "?").c_str(),
              j.value("fusion_method", "?").c_str(), j.value("updates_per_s", 0.0), j.value("latency_ms", 0.0),
              static_cast<unsigned long long>(j.value("updates", 0ULL)));
  // Percentiles over the daemon's last status interval (null = no samples, or an older daemon).
  auto ms = [&j](const char* key, const char* p) {
    const auto& v = j.value(key, nlohmann::json::object());
    return v.contains(p) && v[p].is_number() ? fmt::format("{:.1f}", v[p].get<double>()) : std::string("-");
  };
  std::printf(
      "  latency: processing (delivered -> sendto) p50 %s p99 %s ms, capture (capture -> sendto) p50 %s p99 %s ms\n",
      ms("processing_latency_ms", "p50").c_str(), ms("processing_latency_ms", "p99").c_str(),
      ms("capture_latency_ms", "p50").c_str(), ms("capture_latency_ms", "p99").c_str());
  for (const auto& c : j.value("cameras", nlohmann::json::array())) {
    std::printf("  %-10s %-5s %5.1f fps  detect %5.1f ms  %4.1f markers  drops %llu  corrupt %llu  errors %llu  %s\n",
                c.value("name", "?").c_str(), c.value("state", "?").c_str(), c.value("fps", 0.0),
                c.value("detect_ms", 0.0), c.value("markers", 0.0),
                static_cast<unsigned long long>(c.value("drops", 0ULL)),
                static_cast<unsigned long long>(c.value("corrupt", 0ULL)),
                static_cast<unsigned long long>(c.value("errors", 0ULL)), c.value("source", "").c_str());
    const std::string err = c.value("last_error", "");
    if (c.value("state", "") != "open" && !err.empty()) std::printf("             last error: %s\n", err.c_str());
    // Fixed reference markers as this camera alone maps them (a bumped camera shows here).
    for (const auto& f : c.value("fixed_markers", nlohmann::json::array()))
      std::printf("             fixed marker %d: %.1f cm from its surveyed position%s%s\n", f.value("id", -1),
                  100 * f.value("error_m", 0.0), f.value("seen", false) ? "" : " (not seen in the last second)",
                  f.value("moved", false) ? "  MAY HAVE MOVED" : "");
  }
  for (const auto& out : j.value("outputs", nlohmann::json::array())) {
    std::printf("  output %s: %llu datagrams, %llu send errors", out.value("output", "?").c_str(),
                static_cast<unsigned long long>(out.value("datagrams", 0ULL)),
                static_cast<unsigned long long>(out.value("send_errors", 0ULL)));
    // Type-specific counters (subscriptions: subscribers, refusals by reason, ...).
    for (const auto& [name, value] : out.items())
      if (value.is_number_unsigned() && name != "datagrams" && name != "send_errors" && name != "bytes")
        std::printf(", %s %llu", name.c_str(), static_cast<unsigned long long>(value.get<std::uint64_t>()));
    std::printf("\n");
  }
  // The range input (ranging:): what arrived, what was refused and why, what was solved.
  if (const auto r = j.value("ranging", nlohmann::json::object()); !r.empty()) {
    const auto count = [](const nlohmann::json& doc, const char* k) {
      return static_cast<unsigned long long>(doc.value(k, 0ULL));
    };
    std::printf("  ranging port %d: %llu datagrams, %llu taken, %llu fixes", r.value("port", 0), count(r, "datagrams"),
                count(r, "accepted"), count(r, "fixes"));
    // Named, not temporaries: items() refers to its object, which must outlive the loop.
    const auto refused = r.value("refused", nlohmann::json::object());
    const auto failed = r.value("fixes_failed", nlohmann::json::object());
    for (const auto& [why, n] : refused.items())
      if (n.is_number_unsigned() && n.get<std::uint64_t>() > 0)
        std::printf(", refused %s %llu", why.c_str(), static_cast<unsigned long long>(n.get<std::uint64_t>()));
    for (const auto& [why, n] : failed.items())
      if (n.is_number_unsigned())
        std::printf(", unsolved %s %llu", why.c_str(), static_cast<unsigned long long>(n.get<std::uint64_t>()));
    if (count(r, "unknown_references")) std::printf(", unknown references %llu", count(r, "unknown_references"));
    std::printf("\n");
    // ranging.track: what the ranges did to the tracks, and each tag's learnt anchor biases.
    if (const auto ranges = r.value("ranges", nlohmann::json::object()); !ranges.empty()) {
      std::printf("    ranges:");
      for (const auto& [what, n] : ranges.items())
        if (n.is_number_unsigned())
          std::printf(" %s %llu", what.c_str(), static_cast<unsigned long long>(n.get<std::uint64_t>()));
      std::printf("; camera positions used %llu\n", count(r, "camera_references"));
    }
    // Counts by word on one line: what odometry did; what ranges to other tags did to those
    // tags' own tracks (ranging.track.mutual).
    for (const auto& [key, label] :
         {std::pair{"odometry", "odometry"}, std::pair{"mutual", "ranges to tags, on their tracks"}}) {
      const auto counts = r.value(key, nlohmann::json::object());
      if (counts.empty()) continue;
      std::printf("    %s:", label);
      for (const auto& [what, n] : counts.items())
        if (n.is_number_unsigned())
          std::printf(" %s %llu", what.c_str(), static_cast<unsigned long long>(n.get<std::uint64_t>()));
      std::printf("\n");
    }
    // The daemon's survey of its anchors from the ranges taken under the cameras.
    for (const auto& a : r.value("anchors", nlohmann::json::array())) {
      if (!a.is_object()) continue;
      std::printf("    anchor %llu: %llu ranges under the cameras", count(a, "id"), count(a, "samples"));
      if (a.value("status", std::string()) != "ok") {
        std::printf("; %s\n", a.contains("status") ? ("not placed: " + a.value("status", std::string())).c_str()
                                                   : "no estimate yet");
        continue;
      }
      const std::string what = a.value("estimated", std::string());
      // 1-sigma of x, y, z and bias: a shift within ~2 sigma is what these ranges cannot tell
      // from none (samples from a small part of the room trade position against bias).
      const auto sigma = a.value("sigma_m", std::vector<double>{});
      const double position_sigma = sigma.size() == 4 ? std::sqrt(sigma[0] * sigma[0] + sigma[1] * sigma[1] +
                                                                  (what == "horizontal" ? 0.0 : sigma[2] * sigma[2]))
                                                      : 0.0;
      if (what != "bias") {
        const auto p = a.value("position", std::vector<double>{}), c = a.value("configured", std::vector<double>{});
        if (p.size() == 3 && c.size() == 3)
          std::printf("; %.1f +- %.1f cm from its configured position (%+.1f %+.1f %+.1f cm%s)",
                      100 * a.value("moved_m", 0.0), 100 * position_sigma, 100 * (p[0] - c[0]), 100 * (p[1] - c[1]),
                      100 * (p[2] - c[2]), what == "horizontal" ? ", height as configured" : "");
      } else {
        std::printf("; position not determined by these ranges");
      }
      std::printf("; reads %+.1f +- %.1f cm beyond its bias; rms %.1f cm\n", 100 * a.value("bias_m", 0.0),
                  100 * (sigma.size() == 4 ? sigma[3] : 0.0), 100 * a.value("rms_m", 0.0));
    }
    const auto tracks = r.value("tracks", nlohmann::json::array());
    for (const auto& t : tracks) {
      if (!t.is_object()) continue;
      std::printf(
          "    tag %llu: %s, %llu restarts, %llu late ranges replayed; %s (cm):", count(t, "tag"),
          t.value("started", false) ? "tracking" : "waiting for a first fix", count(t, "restarts"),
          count(t, "replayed"),
          t.value("learning_bias", false) ? "learnt bias" : "bias not learnt (few anchors, no camera reference)");
      const auto biases = t.value("biases", nlohmann::json::object());
      for (const auto& [anchor, b] : biases.items())
        if (b.is_number()) std::printf(" %s %+.1f", anchor.c_str(), 100.0 * b.get<double>());
      std::printf("\n");
    }
  }
  return 0;
}

IPS_REGISTER_COMMAND("status", "Show a running ipsd's per-camera status (reads its status.socket)",
                     [](CLI::App& sub) -> std::function<int()> {
                       auto o = std::make_shared<StatusOptions>();
                       sub.add_option("--socket", o->socket, "the daemon's status.socket")->capture_default_str();
                       sub.add_flag("--json", o->json, "print the daemon's JSON document as is");
                       return [o] { return run_status(*o); };
                     });

}  // namespace cmd_status
