#!/usr/bin/env bash
# The README's first command: the whole system on three simulated cameras, no hardware needed.
#   1. install the Debian packages needed to build and run (tools/setup.sh: not the test tools),
#   2. build the two programs (Release),
#   3. fit the camera->world model once, on calibration pairs collected in the simulator
#      (`ips sim collect` + `ips fit --method plane`, into build/demo/),
#   4. run ipsd on config/demo.yaml (three synthetic cameras of the published lab, four robots)
#      and show its UDP stream live with `ips listen`; the web view is on (the URL is printed).
#      Step 4 is packaging/ipsd-demo, the script the Debian package installs as ipsd-demo.
# Usage: bash tools/demo.sh [SECONDS]     run until Ctrl-C, or for SECONDS
# Ctrl-C (or the time limit) stops the listener and then the daemon; nothing is left running.
set -euo pipefail
cd "$(dirname "$0")/.."
duration=${1:-0}

bash tools/setup.sh
# An existing release build (tools/test.sh's, tools/package.sh's) is reused as it is configured;
# otherwise build/programs (tools/configure_programs.sh: Release in unity batches, no tests).
if [ -f build/release/CMakeCache.txt ] && ! grep -q '^IPS_SANITIZE:BOOL=ON' build/release/CMakeCache.txt; then
  bin=build/release
else
  bin=build/programs
  bash tools/configure_programs.sh
fi
cmake --build "$bin" -j "$(nproc)" --target ips_tool ipsd

mkdir -p build/demo
if [[ ! -s build/demo/model.json || config/scenes/ou2023.yaml -nt build/demo/model.json ]]; then
  echo "== demo: fitting the camera->world model on simulated calibration pairs (once)"
  "$bin/ips" sim collect --scene config/scenes/ou2023.yaml --points 40 --out build/demo/pairs.csv
  "$bin/ips" fit --data build/demo/pairs.csv --method plane --out build/demo/model.json
fi

# The config it runs, the daemon's log and the status socket go to build/demo/.
exec bash packaging/ipsd-demo --bin "$bin" --config config/demo.yaml --state build/demo "$duration"
