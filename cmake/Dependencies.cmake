# Every dependency is a Debian 12 package installed by tools/setup.sh.
# Nothing is downloaded at configure or build time.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(OpenCV 4.5 REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d aruco videoio)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(NLopt 2.7 REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(spdlog REQUIRED)
pkg_check_modules(TURBOJPEG REQUIRED IMPORTED_TARGET libturbojpeg)
# libjpeg's own API (same libjpeg-turbo package): partial decodes for tracking (jpeg_crop_scanline).
pkg_check_modules(LIBJPEG REQUIRED IMPORTED_TARGET libjpeg)
pkg_check_modules(SYSTEMD REQUIRED IMPORTED_TARGET libsystemd)

add_library(ips_deps INTERFACE)
target_include_directories(ips_deps SYSTEM INTERFACE ${OpenCV_INCLUDE_DIRS})
target_link_libraries(ips_deps INTERFACE
  ${OpenCV_LIBS} Eigen3::Eigen ${NLOPT_LIBRARIES} yaml-cpp nlohmann_json::nlohmann_json
  CLI11::CLI11 spdlog::spdlog PkgConfig::TURBOJPEG PkgConfig::LIBJPEG PkgConfig::SYSTEMD Threads::Threads)

# HMAC-SHA256 and a CSPRNG for the subscriptions output (cookies, pre-shared key).
pkg_check_modules(SODIUM REQUIRED IMPORTED_TARGET libsodium)
target_link_libraries(ips_deps INTERFACE PkgConfig::SODIUM)
