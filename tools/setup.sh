#!/usr/bin/env bash
# Installs the Debian 12 packages ipsd needs, in two layers:
#   bash tools/setup.sh          build and run: compiler, libraries, what the package build uses
#                                (tools/demo.sh, tools/package.sh)
#   bash tools/setup.sh --test   the above, plus what the test suite adds: GoogleTest, Google
#                                Benchmark, clang-14 for the sanitizer/fuzz build, chromium for the
#                                web view's tests, node-mavlink (npm) for the MAVLink tests and
#                                lintian for the package test (tools/test.sh)
# Idempotent: packages already present are left as they are.
set -euo pipefail

layer=run
case "${1:-}" in
  "") ;;
  --test) layer=test ;;
  *) echo "setup.sh: unknown option '$1' (usage: setup.sh [--test])" >&2; exit 2 ;;
esac

# Build and run (and build the .deb: tools/package.sh).
PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libopencv-dev libopencv-contrib-dev      # OpenCV 4.6 core/imgproc/calib3d + contrib aruco
  libeigen3-dev                            # linear algebra for the mappers
  libnlopt-cxx-dev                         # kriging maximum-likelihood optimisation
  libturbojpeg0-dev                        # fast MJPEG -> greyscale decode
  libjpeg62-turbo-dev                      # libjpeg API: partial decodes (jpeg_crop_scanline, jpeg_skip_scanlines)
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libspdlog-dev
  libsystemd-dev                           # sd_notify
  linux-libc-dev                           # V4L2 headers
  libceres-dev                             # bundle adjustment for ips survey (camera poses)
  cyclonedds-dev cyclonedds-tools          # ROS 2-compatible DDS output (C API + idlc)
  libcivetweb-dev                          # HTTP + WebSocket server for the web view
  libsodium-dev                            # HMAC-SHA256 + CSPRNG for the subscriptions output
  help2man                                 # the man pages of ipsd and ips, from their --help
  file                                     # cpack: finds the ELF files to strip and to run dpkg-shlibdeps on
  python3                                  # tools/ipsd_client.py
)
# What the test suite adds (tools/test.sh).
TEST_PACKAGES=(
  libgtest-dev libgmock-dev libbenchmark-dev
  chromium                                 # headless browser for the web view's tests
  clang-14 libclang-rt-14-dev               # the sanitizer build and libFuzzer (fuzz/)
  clang-format-14                          # the formatting check (.clang-format)
  libjpeg-turbo-progs                      # cjpeg: fuzz/make_seeds.py writes the JPEG seeds with restart markers
  lintian                                  # tests/package: the .deb checked against Debian policy
)
if [ "$layer" = test ]; then PACKAGES+=("${TEST_PACKAGES[@]}"); fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all packages present ($layer layer)"
fi

if [ "$layer" != test ]; then exit 0; fi

# The MAVLink output's tests decode frames with an independent implementation (node-mavlink),
# pinned by tests/output/mavlink_decoder/package-lock.json. Debian's nodejs/npm only where no
# npm is installed (a NodeSource nodejs already carries its own npm).
if ! command -v npm >/dev/null 2>&1; then
  echo "setup: installing nodejs npm"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends nodejs npm
fi
decoder="$(cd "$(dirname "$0")/.." && pwd)/tests/output/mavlink_decoder"
if [ ! -f "$decoder/node_modules/node-mavlink/package.json" ] || [ "$decoder/package-lock.json" -nt "$decoder/node_modules" ]; then
  echo "setup: npm ci in tests/output/mavlink_decoder"
  npm ci --prefix "$decoder" --no-audit --no-fund --loglevel=error
fi
