#!/usr/bin/env bash
# Configures build/programs: the users' build of the two programs (Release, unity batches, no
# tests or benchmarks: they need the test layer of tools/setup.sh and are not run here). Used by
# tools/demo.sh and tools/package.sh when there is no build/release, and by tools/test.sh, which
# configures it (and compiles the same flags and batches in its release configuration) so that
# the first command of a fresh clone keeps working.
# A clean build of ips and ipsd here: ~3 min on 2 cores (8 min without the unity batches).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build/programs -G Ninja -DCMAKE_BUILD_TYPE=Release -DIPS_SANITIZE=OFF \
      -DIPS_BUILD_TESTS=OFF -DIPS_BUILD_BENCHMARKS=OFF \
      -DIPS_UNITY_BUILD=ON -DIPS_UNITY_PROGRAMS=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16 >/dev/null
