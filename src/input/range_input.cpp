#include "ips/input/range_input.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace ips {

RangeInput::RangeInput(const RangeInputSettings& settings, const std::string& where, Handler on_firing)
    : admission_(settings, where), on_firing_(std::move(on_firing)) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(settings.port);
  if (::inet_pton(AF_INET, settings.address.c_str(), &addr.sin_addr) != 1)
    throw InputError(where + ".address: '" + settings.address + "' is not an IPv4 address to listen on");
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(where + ": socket: " + std::strerror(errno));
  const int rcvbuf = 1 << 20;
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  // A reload opens the new input before the old one closes; the port is shared for that moment.
  const int on = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_REUSEPORT, &on, sizeof on);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd_);
    throw InputError(where + ".port: cannot listen on " + settings.address + ":" + std::to_string(settings.port) +
                     ": " + std::strerror(err));
  }
  socklen_t len = sizeof addr;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
  // The thread takes no signals: ipsd reads SIGTERM/SIGHUP through a signalfd.
  sigset_t all, old;
  sigfillset(&all);
  pthread_sigmask(SIG_BLOCK, &all, &old);
  thread_ = std::thread([this] { receive_loop(); });
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

RangeInput::~RangeInput() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  ::close(fd_);
}

RangeInputCounters RangeInput::counters() const {
  std::lock_guard lock(mutex_);
  return admission_.counters();
}

void RangeInput::receive_loop() {
  std::vector<std::uint8_t> buf(1 << 16);  // any UDP datagram whole: a long one is refused by its size, not cut
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    // Drain what is queued (a flood is handled in bulk, not one poll per datagram).
    for (int i = 0; i < 4096 && !stop_; ++i) {
      sockaddr_in from{};
      socklen_t len = sizeof from;
      const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &len);
      if (n < 0) break;
      std::optional<AdmittedFiring> firing;
      {
        std::lock_guard lock(mutex_);
        firing = admission_.admit(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)),
                                  ntohl(from.sin_addr.s_addr), ntohs(from.sin_port), monotonic_ns(), realtime_ns());
      }
      if (firing && on_firing_) on_firing_(std::move(*firing));
    }
  }
}

}  // namespace ips
