#!/usr/bin/env bash
# The README's main job: the whole system on three simulated cameras, no hardware needed.
#   1. install the Debian packages and build (release),
#   2. fit the camera->world model once, on calibration pairs collected in the simulator
#      (`ips sim collect` + `ips fit --method plane`, into build/demo/),
#   3. run ipsd on config/demo.yaml (three synthetic cameras of the published lab, four robots)
#      and show its UDP stream live with `ips listen`; the web view is on (the URL is printed).
# Usage: bash tools/demo.sh [SECONDS]     run until Ctrl-C, or for SECONDS
# Ctrl-C (or the time limit) stops the listener and then the daemon; nothing is left running.
set -euo pipefail
cd "$(dirname "$0")/.."
duration=${1:-0}

bash tools/setup.sh
# Same tree as tools/test.sh's release build; only the two programs are built here.
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DIPS_SANITIZE=OFF >/dev/null
cmake --build build/release -j "$(nproc)" --target ips_tool ipsd

bin=build/release
mkdir -p build/demo
if [[ ! -s build/demo/model.json || config/scenes/ou2023.yaml -nt build/demo/model.json ]]; then
  echo "== demo: fitting the camera->world model on simulated calibration pairs (once)"
  "$bin/ips" sim collect --scene config/scenes/ou2023.yaml --points 40 --out build/demo/pairs.csv
  "$bin/ips" fit --data build/demo/pairs.csv --method plane --out build/demo/model.json
fi

log=build/demo/ipsd.log
"$bin/ipsd" --config config/demo.yaml >"$log" 2>&1 &
ipsd_pid=$!
stop_daemon() {
  if kill -0 "$ipsd_pid" 2>/dev/null; then
    kill -TERM "$ipsd_pid" 2>/dev/null || true
    wait "$ipsd_pid" 2>/dev/null || true
    echo "== demo: ipsd stopped (its log: $log)"
  fi
}
trap stop_daemon EXIT
trap 'exit 130' INT TERM

# Wait until the cameras are open (each simulated camera precomputes its renderer first).
for _ in $(seq 1 300); do
  grep -q "running:" "$log" 2>/dev/null && break
  if ! kill -0 "$ipsd_pid" 2>/dev/null; then
    wait "$ipsd_pid" && status=0 || status=$?
    echo "== demo: ipsd exited with status $status:" >&2
    cat "$log" >&2
    exit 1
  fi
  sleep 0.1
done
echo "== demo: ipsd is running (pid $ipsd_pid, log $log); live positions follow."
echo "   Its status, from another terminal: $bin/ips status --socket /tmp/ipsd-demo.sock"
web_url=$(sed -n 's/.*web view on \(http[^ ]*\).*/\1/p' "$log" | head -n1)
if [[ -n "$web_url" ]]; then
  echo "   Live view in a browser: $web_url  (floor map, camera views with detections, health)"
fi
echo "   Press Ctrl-C to stop."
"$bin/ips" listen --bind 127.0.0.1:5005 --duration "$duration" || true
