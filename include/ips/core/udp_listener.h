// What every UDP listener of ipsd shares (the range input, the subscription sink): the socket
// opened and bound with errors that name the config key, and a receive thread that takes no
// signals.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <thread>

namespace ips {

/// A nonblocking, close-on-exec UDP socket bound to address:port (port 0: any free one), with
/// a 1 MiB receive buffer and SO_REUSEPORT (a reload opens the new listener before the old one
/// closes; the port is shared, same user only, for that moment). Throws InputError naming
/// `where.address` or `where.port`. The caller owns the descriptor.
int open_udp_listener(const std::string& address, std::uint16_t port, const std::string& where);

/// The port a bound socket listens on (the one the kernel chose for port 0).
std::uint16_t bound_udp_port(int fd);

/// A thread with every signal blocked: ipsd reads SIGTERM/SIGHUP through a signalfd, and a
/// listener may be opened before ipsd blocks them (a thread with them unblocked would be
/// killed by them).
std::thread start_thread_without_signals(std::function<void()> body);

}  // namespace ips
