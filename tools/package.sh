#!/usr/bin/env bash
# Builds the Debian package of ipsd from the release build:
#   bash tools/package.sh            -> build/release/package/ipsd_<version>_<arch>.deb
# Install it with `sudo apt install ./build/release/package/ipsd_*.deb` (README "Install").
set -euo pipefail
cd "$(dirname "$0")/.."

bash tools/setup.sh
build=${IPS_BUILD_DIR:-build/release}
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DIPS_SANITIZE=OFF >/dev/null
fi
if grep -q '^IPS_SANITIZE:BOOL=ON' "$build/CMakeCache.txt"; then
  echo "package.sh: $build is a sanitizer build; package a release build (IPS_BUILD_DIR=build/release)" >&2
  exit 2
fi
cmake --build "$build" -j "$(nproc)" --target ips_tool ipsd
(cd "$build" && cpack -G DEB -B package)
ls -1 "$build"/package/*.deb
