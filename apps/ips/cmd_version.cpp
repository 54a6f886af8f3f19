// `ips version`: what was built, with which libraries (useful in bug reports).
#include <cstdio>

#include <opencv2/core/version.hpp>

#include "command.h"

namespace cmd_version {  // named, not anonymous: unique in a unity build
IPS_REGISTER_COMMAND("version", "Print the version of ips and of the libraries it uses",
                     [](CLI::App&) -> std::function<int()> {
                       return [] {
                         std::printf("ips %s (OpenCV %s)\n", IPS_VERSION, CV_VERSION);
                         return 0;
                       };
                     });
}  // namespace cmd_version
