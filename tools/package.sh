#!/usr/bin/env bash
# Builds the Debian package of ipsd from a release build:
#   bash tools/package.sh     -> build/package/ipsd_<version>_<arch>.deb
#                                (and its debug symbols, build/package/ipsd-dbgsym_<version>_<arch>.ddeb)
# Install it with `sudo apt install ./build/package/ipsd_*.deb` (docs/install.md).
# Installs only what building needs (tools/setup.sh, not the test layer). The build: IPS_BUILD_DIR
# if set; else build/release when it is configured (tools/test.sh's); else build/programs
# (tools/configure_programs.sh, as tools/demo.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

bash tools/setup.sh
if [ -n "${IPS_BUILD_DIR:-}" ]; then
  build=$IPS_BUILD_DIR
elif [ -f build/release/CMakeCache.txt ]; then
  build=build/release
else
  build=build/programs
fi
if [ "$build" = build/programs ] || [ ! -f "$build/CMakeCache.txt" ]; then
  if [ "$build" != build/programs ]; then
    echo "package.sh: $build is not configured (configure it, or leave IPS_BUILD_DIR unset)" >&2
    exit 2
  fi
  bash tools/configure_programs.sh
else
  # Configured before help2man was installed: look for it again (the man pages need it).
  cmake "$build" >/dev/null
fi
if grep -q '^IPS_SANITIZE:BOOL=ON' "$build/CMakeCache.txt"; then
  echo "package.sh: $build is a sanitizer build; package a release build (IPS_BUILD_DIR=build/release)" >&2
  exit 2
fi
cmake --build "$build" -j "$(nproc)" --target ips_tool ipsd ips_examples ips_man ips_changelog
out=$PWD/build/package
rm -f "$out"/ipsd_*.deb "$out"/ipsd-dbgsym_*.ddeb
(cd "$build" && cpack -G DEB -B "$out")
ls -1 "$out"/ipsd_*.deb "$out"/ipsd-dbgsym_*.ddeb
