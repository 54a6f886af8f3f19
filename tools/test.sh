#!/usr/bin/env bash
# The whole test suite, from a fresh Debian 12 machine:
#   1. install the Debian packages (tools/setup.sh),
#   2. check the formatting of every C and C++ file against .clang-format (clang-format-14),
#   3. configure the two programs as tools/demo.sh does on a fresh clone (build/programs),
#   4. build and test the release configuration, libips and the programs in the users' unity
#      batches (so the users' build is the one tested; it is not built a second time),
#   5. build and test again under AddressSanitizer + UBSan, with clang: the fuzz targets (fuzz/)
#      are libFuzzer programs there and each fuzzes for a few seconds (gcc's release build
#      replays their corpora once).
# Usage: bash tools/test.sh            (both configurations)
#        IPS_TEST_CONFIGS=release bash tools/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."

bash tools/setup.sh --test

jobs=$(nproc)
# Formatting: the tree is formatted with `clang-format-14 -i` (tools/format.sh); a file that
# differs fails here with the lines clang-format would change.
echo "=== formatting: clang-format-14 --dry-run --Werror ==="
bash tools/format.sh --check
# The users' configuration (tools/demo.sh's on a fresh clone: no tests, no benchmarks) must
# configure; its compile is the release configuration's below (same flags, same batches).
echo "=== programs: configure (build/programs, tools/configure_programs.sh) ==="
bash tools/configure_programs.sh
configs=${IPS_TEST_CONFIGS:-"release asan"}
for config in $configs; do
  build="build/$config"
  case "$config" in
    release) flags=(-DCMAKE_BUILD_TYPE=Release -DIPS_SANITIZE=OFF -DIPS_BUILD_TESTS=ON -DIPS_FUZZ=ON
                    -DIPS_UNITY_BUILD=ON -DIPS_UNITY_PROGRAMS=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16) ;;
    # -O1 keeps image-heavy tests quick under the sanitizers without hiding errors; -g1 (line
    # tables) is all a sanitizer report needs and compiles faster than full debug info.
    asan)    flags=(-DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14
                    -DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-g1 -O1" "-DCMAKE_C_FLAGS_DEBUG=-g1 -O1"
                    -DIPS_SANITIZE=ON -DIPS_BUILD_TESTS=ON -DIPS_BUILD_BENCHMARKS=OFF -DIPS_FUZZ=ON
                    -DIPS_UNITY_BUILD=OFF -DIPS_UNITY_PROGRAMS=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16) ;;
    *) echo "test.sh: unknown configuration '$config' (release|asan)" >&2; exit 2 ;;
  esac
  echo "=== $config: configure + build ($build) ==="
  cmake -S . -B "$build" -G Ninja "${flags[@]}"
  cmake --build "$build" -j "$jobs"
  echo "=== $config: ctest ==="
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  (cd "$build" && ctest --output-on-failure -j "$jobs")
done
