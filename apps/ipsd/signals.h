// The signals the daemon reads synchronously (SIGTERM, SIGINT: stop; SIGHUP: reload) and the
// one rule that makes that work: they are blocked in every thread of the process. A thread
// with them unblocked would take the signal itself and its default action would end the
// process (a reload that kills the daemon). main() blocks them before anything else runs, so
// every thread started later — ours, DDS's, the web server's, a library's — inherits the mask;
// the daemon reads them through a signalfd and refuses to run on a thread without the mask.
#pragma once

#include <signal.h>

namespace ipsd {

/// SIGTERM, SIGINT and SIGHUP.
sigset_t daemon_signals();

/// Blocks daemon_signals() in the calling thread; call it in main() before any thread exists.
/// Throws std::runtime_error if the kernel refuses.
void block_daemon_signals();

/// True if every one of daemon_signals() is blocked in the calling thread.
bool daemon_signals_blocked();

/// A non-blocking signalfd for daemon_signals(); throws std::logic_error if they are not
/// blocked in the calling thread (the signals would not reach the fd), std::runtime_error if
/// the kernel refuses. The caller closes it.
int open_daemon_signalfd();

}  // namespace ipsd
