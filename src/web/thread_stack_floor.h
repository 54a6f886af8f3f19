// The floor thread_stack_floor.cpp puts under every stack size a library asks for (CivetWeb's
// worker threads); not part of the public API.
#pragma once

#include <cstddef>

namespace ips::web_detail {

/// The floor, bytes. Calling it is what links thread_stack_floor.cpp (and its definition of
/// pthread_attr_setstacksize) into a program from the static libips.
std::size_t thread_stack_floor();

}  // namespace ips::web_detail
