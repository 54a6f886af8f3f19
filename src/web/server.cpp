// CivetWeb glue: one catch-all request handler routes with route_request(); CivetWeb itself
// answers requests it cannot parse (400). CivetWeb (1.15) holds one worker thread per
// connection from accept until the request is answered, so the pool is sized to keep the page
// reachable: num_threads = max_connections + max_clients (live streams never take the threads
// of other requests), an idle socket is closed after request_timeout (no keep-alive), and one
// client address has at most max_per_address requests and streams in progress (more: 503).
#include <civetweb.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <system_error>
#include <thread>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/web/web.h"
#include "stream_hub.h"
#include "thread_stack_floor.h"

namespace ips {

namespace {
// A camera that delivers nothing within this time gets a 503 (down, or stopped).
constexpr std::int64_t kFrameWaitNs = 1'000'000'000;
// Stream keep-alive comment period: also how soon a vanished client is noticed.
constexpr int kKeepAliveMs = 1000;

struct ViewCache {
  std::mutex mutex;  // one encoder per camera at a time; concurrent viewers share its result
  std::int64_t made_ns = 0;
  std::shared_ptr<const CameraView> view;
};

struct CameraEntry {
  std::shared_ptr<FrameTap> tap;
  std::shared_ptr<ViewCache> cache;
};

// `head`: a HEAD request gets the same status line and headers (Content-Length of the body a
// GET would get) and no body.
int send(mg_connection* conn, bool head, int status, const char* mime, const std::string& body,
         const char* extra = "") {
  mg_printf(conn,
            "HTTP/1.1 %d %s\r\nContent-Type: %s\r\nContent-Length: %zu\r\nCache-Control: no-store\r\n"
            "X-Content-Type-Options: nosniff\r\n%sConnection: close\r\n\r\n",
            status, mg_get_response_code_text(conn, status), mime, body.size(), extra);
  if (!head) mg_write(conn, body.data(), body.size());
  return status;
}
}  // namespace

struct WebServer::Impl {
  WebConfig config;
  std::string dictionary;
  mg_context* ctx = nullptr;
  web::StreamHub hub;
  std::mutex mutex;  // layout, status, cameras
  std::string layout_text = "{}", status_text = "{}";
  std::map<std::string, CameraEntry> cameras;
  std::atomic<std::uint64_t> frames{0}, bad_requests{0}, messages{0}, limited{0};
  std::string start_error;
  std::mutex address_mutex;
  std::map<std::string, int> in_progress;  // client address -> requests being served (streams included)

  /// Takes one of the address's max_per_address slots (false: none left).
  bool enter(const std::string& address) {
    std::lock_guard lock(address_mutex);
    int& n = in_progress[address];
    if (n >= config.max_per_address) return false;
    ++n;
    return true;
  }
  void leave(const std::string& address) {
    std::lock_guard lock(address_mutex);
    if (--in_progress[address] <= 0) in_progress.erase(address);
  }

  Impl(const WebConfig& c, std::string dict) : config(c), dictionary(std::move(dict)), hub(c.update_rate_hz) {}

  int error(mg_connection* conn, bool head, int status, const std::string& what, const char* extra = "") {
    ++bad_requests;
    return send(conn, head, status, "text/plain; charset=utf-8", what + "\n", extra);
  }

  int handle(mg_connection* conn) {
    const mg_request_info* ri = mg_get_request_info(conn);
    const std::string method = ri->request_method ? ri->request_method : "";
    const std::string path = ri->local_uri ? ri->local_uri : "";
    const std::string query = ri->query_string ? ri->query_string : "";
    Route r = route_request(method, path);
    const bool head = r.head;
    // Read-only: a request with a body (or a body length that is no number) is malformed here.
    const char* length = mg_get_header(conn, "Content-Length");
    if (r.kind != Route::Kind::kBadMethod &&
        ((length && std::strcmp(length, "0") != 0) || mg_get_header(conn, "Transfer-Encoding")))
      r.kind = Route::Kind::kBadRequest;
    switch (r.kind) {
      case Route::Kind::kBadRequest: return error(conn, head, 400, "bad request (path, or a body on a GET)");
      case Route::Kind::kBadMethod:
        return error(conn, false, 405, "read-only: only GET and HEAD are served", "Allow: GET, HEAD\r\n");
      case Route::Kind::kNotFound: return error(conn, head, 404, "no such page: " + path);
      case Route::Kind::kPage:
      case Route::Kind::kAsset: {
        const Asset* a = find_asset(r.kind == Route::Kind::kPage ? "index.html" : r.name);
        if (!a) return error(conn, head, 404, "no such asset: " + r.name);
        return send(conn, head, 200, a->mime, std::string(reinterpret_cast<const char*>(a->data), a->size));
      }
      case Route::Kind::kStatus: {
        std::string body;
        {
          std::lock_guard lock(mutex);
          body = status_text;
        }
        return send(conn, head, 200, "application/json", body + "\n");
      }
      case Route::Kind::kLayout: {
        std::string body;
        {
          std::lock_guard lock(mutex);
          body = layout_text;
        }
        return send(conn, head, 200, "application/json", body + "\n");
      }
      case Route::Kind::kEvents: return stream(conn, head);
      case Route::Kind::kCameraJpeg:
      case Route::Kind::kCameraJson: return camera(conn, r, query);
    }
    return error(conn, head, 500, "unrouted");
  }

  int stream(mg_connection* conn, bool head) {
    static const char* kHeader =
        "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n"
        "Connection: close\r\n\r\n";
    if (head) {  // the headers a stream starts with; no stream (and no slot taken)
      mg_printf(conn, "%s", kHeader);
      return 200;
    }
    auto client = hub.subscribe(static_cast<std::size_t>(config.max_clients));
    if (!client) return error(conn, false, 503, "too many live streams (web.max_clients)");
    mg_printf(conn, "%sretry: 1000\n\n", kHeader);
    // This HTTP thread is the client's writer: a slow reader blocks only here (CivetWeb's
    // request_timeout_ms bounds a write), its queue overflows, the hub counts the drops.
    static const std::string keepalive = ": keep-alive\n\n";
    for (;;) {
      const web::Message m = client->pop(kKeepAliveMs);
      const std::string& text = m ? *m : keepalive;
      if (!m && client->closed()) break;                         // the server is stopping
      if (mg_write(conn, text.data(), text.size()) <= 0) break;  // gone (reset, closed, timed out)
      if (m) ++messages;
    }
    hub.unsubscribe(client);
    return 200;
  }

  int camera(mg_connection* conn, const Route& r, const std::string& query) {
    CameraEntry entry;
    {
      std::lock_guard lock(mutex);
      const auto it = cameras.find(r.name);
      if (it == cameras.end()) return error(conn, r.head, 404, "no camera named '" + r.name + "'");
      entry = it->second;
    }
    std::shared_ptr<const CameraView> view;
    {
      std::lock_guard lock(entry.cache->mutex);
      const std::int64_t now = monotonic_ns();
      const auto min_interval = static_cast<std::int64_t>(1e9 / config.camera_fps);
      // .json after .jpg (the page and the tests read both) must describe the same frame:
      // only a .jpg request takes a new frame.
      const bool fresh =
          entry.cache->view && (r.kind == Route::Kind::kCameraJson || now - entry.cache->made_ns < min_interval);
      if (!fresh) {
        const auto snapshot = entry.tap->request(kFrameWaitNs);
        if (snapshot) {
          entry.cache->view =
              std::make_shared<const CameraView>(render_camera_view(r.name, *snapshot, config.image_width, dictionary));
          entry.cache->made_ns = monotonic_ns();
          ++frames;
        }
      }
      view = entry.cache->view;
    }
    if (!view) return error(conn, r.head, 503, "camera '" + r.name + "' delivers no frames");
    if (r.kind == Route::Kind::kCameraJson) return send(conn, r.head, 200, "application/json", view->info + "\n");
    const bool plain = query.find("overlay=0") != std::string::npos;
    return send(conn, r.head, 200, "image/jpeg", plain ? view->plain_jpeg : view->jpeg);
  }
};

namespace {
int handle_on_this_thread(mg_connection* conn, WebServer::Impl* impl) {
  try {
    return impl->handle(conn);
  } catch (const std::exception& e) {
    spdlog::warn("web: {}", e.what());
    return send(conn, false, 500, "text/plain", std::string("internal error: ") + e.what() + "\n");
  }
}

// CivetWeb's request threads get the stack size fixed when the library was built (Debian's:
// 100 KiB), too small for OpenCV's encoder and ArUco search in the camera view, and overflowed
// under the sanitizers even by plain pages. So each request is handled on a thread with the
// default stack while CivetWeb's thread waits; a stream's thread lives as long as the stream.
/// A request on the roomy thread: the address's slot (or a 503 without one), then the route.
int handle_within_limits(mg_connection* conn, WebServer::Impl* impl) {
  const mg_request_info* ri = mg_get_request_info(conn);
  const std::string address = ri->remote_addr;
  if (!impl->enter(address)) {  // this address has max_per_address requests or streams in progress
    ++impl->limited;
    if (ri->local_uri && std::strcmp(ri->local_uri, "/events") == 0) ++impl->hub.refused;
    const bool head = ri->request_method && std::strcmp(ri->request_method, "HEAD") == 0;
    return impl->error(conn, head, 503, "too many requests in progress from " + address + " (web.max_per_address)",
                       "Retry-After: 1\r\n");
  }
  struct Leave {
    WebServer::Impl* impl;
    const std::string& address;
    ~Leave() { impl->leave(address); }
  } leave{impl, address};
  return handle_on_this_thread(conn, impl);
}

int handle_request(mg_connection* conn, void* data) {
  auto* impl = static_cast<WebServer::Impl*>(data);
  int status = 0;
  try {
    // Every answer, the 503 of a limited address too, is written from the roomy thread: even
    // mg_printf overflowed CivetWeb's own stack under the sanitizers.
    std::thread worker([&] { status = handle_within_limits(conn, impl); });
    worker.join();
  } catch (const std::system_error& e) {  // no thread: answer on this one, briefly
    spdlog::warn("web: cannot start a request thread: {}", e.what());
    return send(conn, false, 503, "text/plain", "busy\n");
  }
  return status;
}

int log_message(const mg_connection* conn, const char* message) {
  if (auto* impl = static_cast<WebServer::Impl*>(mg_get_user_data(mg_get_context(conn)))) {
    if (impl->ctx == nullptr) impl->start_error = message;  // while starting: why it failed
  }
  spdlog::debug("web: {}", message);
  return 1;
}

std::once_flag library_once;
}  // namespace

WebServer::WebServer(const WebConfig& config, const std::string& dictionary)
    : impl_(std::make_unique<Impl>(config, dictionary)) {
  std::call_once(library_once, [] { mg_init_library(0); });
  // CivetWeb's worker threads get at least this much stack (thread_stack_floor.cpp: glibc puts
  // the libraries' static TLS inside the 100 KiB CivetWeb asks for).
  spdlog::debug("web view: thread stacks at least {} KiB", web_detail::thread_stack_floor() / 1024);
  const std::string listen = config.host + ":" + std::to_string(config.port);
  // Every stream holds a thread for its lifetime; the other connections get max_connections
  // threads of their own, each held from accept until answered (an idle socket:
  // request_timeout, also the limit on one blocked write). The queue and backlog let a burst
  // of connections wait for a thread rather than being refused by the kernel.
  const std::string threads = std::to_string(config.max_connections + config.max_clients);
  const std::string timeout_ms = std::to_string(std::lround(config.request_timeout_s * 1000));
  const std::string queue = std::to_string(config.max_connections);
  const char* options[] = {"listening_ports",
                           listen.c_str(),
                           "num_threads",
                           threads.c_str(),
                           "request_timeout_ms",
                           timeout_ms.c_str(),
                           "enable_keep_alive",
                           "no",
                           "connection_queue",
                           queue.c_str(),
                           "listen_backlog",
                           "512",
                           "enable_directory_listing",
                           "no",
                           nullptr};
  mg_callbacks callbacks{};
  callbacks.log_message = log_message;
  mg_init_data init{};
  init.callbacks = &callbacks;
  init.user_data = impl_.get();
  init.configuration_options = options;
  char text[256] = "";
  unsigned code = 0;
  mg_error_data err{&code, text, sizeof text};
  impl_->ctx = mg_start2(&init, &err);
  if (!impl_->ctx) {
    impl_->hub.stop();
    throw InputError("web.listen: cannot serve on " + listen + ": " + (text[0] ? text : impl_->start_error));
  }
  mg_set_request_handler(impl_->ctx, "/", handle_request, impl_.get());
  mg_server_port ports[4] = {};
  const int n = mg_get_server_ports(impl_->ctx, 4, ports);
  port_ = n > 0 ? ports[0].port : config.port;
  spdlog::info("web view on http://{}:{}/", config.host, port_);
}

WebServer::~WebServer() {
  impl_->hub.stop();    // closes every stream's queue: their threads return
  mg_stop(impl_->ctx);  // waits for every request thread
}

std::vector<std::shared_ptr<FrameTap>> WebServer::set_cameras(const std::vector<std::string>& names) {
  std::vector<std::shared_ptr<FrameTap>> taps;
  std::lock_guard lock(impl_->mutex);
  impl_->cameras.clear();
  for (const auto& n : names) {
    CameraEntry e{std::make_shared<FrameTap>(), std::make_shared<ViewCache>()};
    impl_->cameras[n] = e;
    taps.push_back(e.tap);
  }
  return taps;
}

void WebServer::set_layout(std::string json) {
  std::lock_guard lock(impl_->mutex);
  impl_->layout_text = std::move(json);
}

void WebServer::set_status(std::string json) {
  impl_->hub.set_status(json);
  std::lock_guard lock(impl_->mutex);
  impl_->status_text = std::move(json);
}

void WebServer::publish(const Datagram& update) { impl_->hub.publish(update); }

WebCounters WebServer::counters() const {
  WebCounters c;
  c.clients = impl_->hub.clients();
  c.clients_total = impl_->hub.clients_total;
  c.refused = impl_->hub.refused;
  c.messages = impl_->messages;
  c.dropped = impl_->hub.dropped;
  c.inbox_dropped = impl_->hub.inbox_dropped;
  c.frames = impl_->frames;
  c.bad_requests = impl_->bad_requests;
  c.limited = impl_->limited;
  return c;
}

}  // namespace ips
