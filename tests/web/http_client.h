// A minimal HTTP/1.1 client on a raw TCP socket for the web view's tests: raw requests (also
// malformed ones), whole responses, and a Server-Sent-Events reader.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "loopback_udp.h"

namespace ips::test {

class TcpClient {
 public:
  explicit TcpClient(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  ~TcpClient() { close(); }
  TcpClient(const TcpClient&) = delete;
  TcpClient& operator=(const TcpClient&) = delete;
  bool ok() const { return fd_ >= 0; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  /// Closes with a TCP reset (SO_LINGER 0): an abrupt disconnect.
  void reset() {
    if (fd_ < 0) return;
    linger l{1, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_LINGER, &l, sizeof l);
    close();
  }
  bool send_all(const std::string& s) {
    std::size_t off = 0;
    while (off < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
      if (n <= 0) return false;
      off += static_cast<std::size_t>(n);
    }
    return true;
  }
  /// Appends what arrives within `timeout_ms` (returns false at EOF or error).
  bool receive(std::string& out, int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return true;
    char buf[65536];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) return false;
    out.append(buf, static_cast<std::size_t>(n));
    return true;
  }
  /// Everything until EOF or `timeout_ms` in total.
  std::string read_all(int timeout_ms) {
    std::string out;
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (std::chrono::steady_clock::now() < end)
      if (!receive(out, 50)) break;
    return out;
  }

 private:
  int fd_ = -1;
};

struct HttpResponse {
  int status = 0;  ///< 0: no (parsable) answer
  std::string headers, body;
};

inline HttpResponse parse_response(const std::string& raw) {
  HttpResponse r;
  const auto eoh = raw.find("\r\n\r\n");
  if (raw.rfind("HTTP/1.", 0) != 0 || eoh == std::string::npos) return r;
  r.status = std::stoi(raw.substr(9, 3));
  r.headers = raw.substr(0, eoh);
  r.body = raw.substr(eoh + 4);
  return r;
}

inline HttpResponse raw_request(int port, const std::string& request, int timeout_ms = 5000) {
  TcpClient c(port);
  if (!c.ok() || !c.send_all(request)) return {};
  return parse_response(c.read_all(timeout_ms));
}

inline HttpResponse http_get(int port, const std::string& path, int timeout_ms = 5000) {
  return raw_request(port, "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n", timeout_ms);
}

/// Reads a Server-Sent-Events stream: (event, data) pairs.
class EventStream {
 public:
  explicit EventStream(int port) : client_(port) {
    client_.send_all("GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: text/event-stream\r\n\r\n");
  }
  TcpClient& socket() { return client_; }
  /// The next event within `timeout_ms` ({"", ""} if none).
  std::pair<std::string, std::string> next(int timeout_ms) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    for (;;) {
      if (!header_done_) {
        const auto eoh = buffer_.find("\r\n\r\n");
        if (eoh != std::string::npos) {
          status_ = buffer_.substr(0, buffer_.find("\r\n"));
          buffer_.erase(0, eoh + 4);
          header_done_ = true;
        }
      }
      if (header_done_) {
        const auto eoe = buffer_.find("\n\n");
        if (eoe != std::string::npos) {
          const std::string block = buffer_.substr(0, eoe);
          buffer_.erase(0, eoe + 2);
          std::string event, data;
          std::size_t at = 0;
          while (at < block.size()) {
            auto nl = block.find('\n', at);
            if (nl == std::string::npos) nl = block.size();
            const std::string line = block.substr(at, nl - at);
            if (line.rfind("event: ", 0) == 0) event = line.substr(7);
            if (line.rfind("data: ", 0) == 0) data += line.substr(6);
            at = nl + 1;
          }
          if (!event.empty()) return {event, data};
          continue;  // a comment (keep-alive) or the retry hint
        }
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
      if (left.count() <= 0 || !client_.receive(buffer_, static_cast<int>(std::min<long>(left.count(), 100))))
        return {};
    }
  }
  const std::string& status_line() const { return status_; }

 private:
  TcpClient client_;
  std::string buffer_, status_;
  bool header_done_ = false;
};

/// A TCP port that was free a moment ago on 127.0.0.1.
inline int free_tcp_port() { return support::free_loopback_port(SOCK_STREAM); }

}  // namespace ips::test
