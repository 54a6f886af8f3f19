// Small helpers shared by the V4L2 code in src/capture (not a public header).
#pragma once

#include <sys/ioctl.h>

#include <cerrno>
#include <cstdint>
#include <string>

namespace ips::v4l2 {

/// ioctl() retried on EINTR (a signal arriving mid-call must not look like a device error).
inline int xioctl(int fd, unsigned long request, void* arg) {
  int r = 0;
  do {
    r = ::ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

/// "MJPG", "YUYV", ... from a V4L2 fourcc.
inline std::string fourcc_string(std::uint32_t fourcc) {
  std::string s(4, ' ');
  for (int i = 0; i < 4; ++i) s[static_cast<std::size_t>(i)] = static_cast<char>((fourcc >> (8 * i)) & 0xff);
  return s;
}

}  // namespace ips::v4l2
