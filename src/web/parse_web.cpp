#include "web/parse_web.h"

#include <arpa/inet.h>

#include <cmath>
#include <cstdlib>

#include "core/map_reader.h"

namespace ips::config_detail {

void parse_web(const YAML::Node& node, const std::string& file, WebConfig& w) {
  MapReader r(node, "web", file);
  r.get("listen", w.listen, true);
  const auto colon = w.listen.rfind(':');
  const std::string host = colon == std::string::npos ? "" : w.listen.substr(0, colon);
  const std::string port = colon == std::string::npos ? "" : w.listen.substr(colon + 1);
  in_addr addr{};
  if (host.empty() || (host != "localhost" && ::inet_pton(AF_INET, host.c_str(), &addr) != 1))
    r.fail(r.raw()["listen"], "web.listen", "expected IPV4-ADDRESS:PORT (e.g. 127.0.0.1:8080), got '" + w.listen + "'");
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || p < 1 || p > 65535)
    r.fail(r.raw()["listen"], "web.listen", "port must be 1..65535, got '" + port + "'");
  w.host = host == "localhost" ? "127.0.0.1" : host;
  w.port = static_cast<int>(p);
  r.get_number("update_rate", w.update_rate_hz, 0.0, true);
  if (w.update_rate_hz > 100) r.fail(r.raw()["update_rate"], "web.update_rate", "must be <= 100 (Hz)");
  r.get_number("camera_fps", w.camera_fps, 0.0, true);
  if (w.camera_fps > 30) r.fail(r.raw()["camera_fps"], "web.camera_fps", "must be <= 30");
  r.get("image_width", w.image_width);
  if (w.image_width < 160 || w.image_width > 4096)
    r.fail(r.raw()["image_width"], "web.image_width", "must be 160..4096 (pixels)");
  r.get("max_clients", w.max_clients);
  if (w.max_clients < 1 || w.max_clients > 256) r.fail(r.raw()["max_clients"], "web.max_clients", "must be 1..256");
  r.get("max_connections", w.max_connections);
  if (w.max_connections < 16 || w.max_connections > 1024)
    r.fail(r.raw()["max_connections"], "web.max_connections", "must be 16..1024");
  r.get("max_per_address", w.max_per_address);
  if (w.max_per_address < 1 || w.max_per_address > 256)
    r.fail(r.raw()["max_per_address"], "web.max_per_address", "must be 1..256");
  r.get_number("request_timeout", w.request_timeout_s, 0.0, true);
  if (w.request_timeout_s < 0.2 || w.request_timeout_s > 60)
    r.fail(r.raw()["request_timeout"], "web.request_timeout", "must be 0.2..60 (seconds)");
  if (r.has("floor")) {
    const YAML::Node f = r.node("floor");
    bool ok = f.IsSequence() && f.size() == 4;
    for (std::size_t i = 0; ok && i < 4; ++i) {
      try {
        w.floor.push_back(f[i].as<double>());
        ok = std::isfinite(w.floor.back());
      } catch (const YAML::Exception&) {
        ok = false;
      }
    }
    if (!ok || !(w.floor[0] < w.floor[2] && w.floor[1] < w.floor[3]))
      r.fail(f, "web.floor", "expected [xmin, ymin, xmax, ymax] in metres with xmin < xmax, ymin < ymax");
  }
  r.finish();
}

}  // namespace ips::config_detail
