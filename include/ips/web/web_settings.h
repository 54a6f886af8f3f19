// The web view's settings (web.* of the lab's configuration). Parsed by src/web/parse_web.cpp.
#pragma once

#include <string>
#include <vector>

namespace ips {

/// The web view (web.*; docs/web.md): off unless `listen` is set.
struct WebConfig {
  std::string listen;          ///< "host:port" as configured; "" = no web server
  std::string host;            ///< IPv4 address to bind (from `listen`; "localhost" = 127.0.0.1)
  int port = 0;                ///< TCP port (from `listen`)
  double update_rate_hz = 20;  ///< fused updates per second sent to each browser, at most
  double camera_fps = 5;       ///< camera view frames per second per camera, at most (taken only on request)
  int image_width = 960;       ///< camera view JPEG width, pixels (frames are downscaled to it)
  int max_clients = 32;        ///< live streams at once; more get 503
  /// Connections at once besides the live streams: HTTP threads = max_connections + max_clients.
  /// A connection holds its thread from accept until answered, an idle one request_timeout_s at most.
  int max_connections = 128;
  /// Requests in progress (live streams included) from one client address at once; more get 503.
  int max_per_address = 8;
  double request_timeout_s = 1.5;  ///< seconds to send a whole request (idle sockets are closed then), and per write
  /// Floor outline drawn on the map: [xmin, ymin, xmax, ymax], metres; empty = none.
  std::vector<double> floor;

  bool operator==(const WebConfig&) const = default;
};

}  // namespace ips
