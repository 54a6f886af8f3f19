#include "ips/input/range_input.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <vector>

#include "ips/core/clock.h"
#include "ips/core/udp_listener.h"

namespace ips {

RangeInput::RangeInput(const RangeInputSettings& settings, const std::string& where, Handler on_firing)
    : admission_(settings, where), on_firing_(std::move(on_firing)) {
  fd_ = open_udp_listener(settings.address, settings.port, where);
  port_ = bound_udp_port(fd_);
  thread_ = start_thread_without_signals([this] { receive_loop(); });
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
