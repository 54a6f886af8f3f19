#include "signals.h"

#include <pthread.h>
#include <sys/signalfd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace ipsd {

sigset_t daemon_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGHUP);
  return set;
}

void block_daemon_signals() {
  const sigset_t set = daemon_signals();
  if (const int err = pthread_sigmask(SIG_BLOCK, &set, nullptr); err != 0)
    throw std::runtime_error(std::string("pthread_sigmask: ") + std::strerror(err));
}

bool daemon_signals_blocked() {
  sigset_t current;
  if (pthread_sigmask(SIG_BLOCK, nullptr, &current) != 0) return false;
  for (const int sig : {SIGTERM, SIGINT, SIGHUP})
    if (sigismember(&current, sig) != 1) return false;
  return true;
}

int open_daemon_signalfd() {
  if (!daemon_signals_blocked())
    throw std::logic_error(
        "ipsd: SIGTERM/SIGINT/SIGHUP are not blocked in the main thread (block_daemon_signals() "
        "must run in main() before any thread starts)");
  const sigset_t set = daemon_signals();
  const int fd = signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK);
  if (fd < 0) throw std::runtime_error(std::string("signalfd: ") + std::strerror(errno));
  return fd;
}

}  // namespace ipsd
