#!/usr/bin/env bash
# The main job on the embedded default: install, build, run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DIPS_BUILD_TESTS=OFF >/dev/null
cmake --build build/release -j "$(nproc)"
exec build/release/ips compare --train calib_data/ou2023/train40.csv
