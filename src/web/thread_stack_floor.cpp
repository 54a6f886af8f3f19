// A floor under the stack size that libraries ask for their threads.
//
// Here, in the web stage, because CivetWeb's threads are the ones that need it: every program
// with a web view gets it (WebServer's constructor calls thread_stack_floor(), which links this
// file in) -- ipsd, and the web tests, whose CivetWeb thread overflowed the same way once the
// release build compiled libips in unity batches.
//
// glibc places a thread's static TLS (every TLS block of the libraries loaded at start) at the
// top of the stack it allocates, inside the size the creator asked for. CivetWeb asks for the
// 100 KiB it was built with (Debian's build); since the range solver brought Ceres into ipsd,
// Ceres' glog and METIS alone take 58 KiB of TLS, and CivetWeb's own answer to a malformed
// request (glibc's printf, on its thread) overflowed what was left: SIGSEGV, found by
// WebBrowserTest.BadRequestsGet4xxAndTheDaemonKeepsStreaming. CivetWeb has no option for its
// stack size, so ipsd defines pthread_attr_setstacksize itself (the executable's definition
// comes first for the shared libraries) and passes at least 1 MiB on to glibc's. Threads that
// ask for more, or for nothing (glibc's default: 8 MiB), are unaffected; the memory is
// virtual until used.
#include <dlfcn.h>
#include <pthread.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>

#include "thread_stack_floor.h"

namespace {
constexpr std::size_t kStackFloor = std::size_t{1} << 20;
using SetStackSize = int (*)(pthread_attr_t*, std::size_t);
}  // namespace

extern "C" int pthread_attr_setstacksize(pthread_attr_t* attr, std::size_t size) {
  static const auto real = reinterpret_cast<SetStackSize>(dlsym(RTLD_NEXT, "pthread_attr_setstacksize"));
  if (!real) return ENOSYS;
  return real(attr, std::max(size, kStackFloor));
}

namespace ips::web_detail {

std::size_t thread_stack_floor() { return kStackFloor; }

}  // namespace ips::web_detail
