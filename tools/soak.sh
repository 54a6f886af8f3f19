#!/usr/bin/env bash
# The soak under faults (docs/reliability.md): ipsd on 3 emulated V4L2 cameras for SECONDS
# with a fault every PERIOD seconds (unplug/replug, corrupt frames, SIGHUP good and bad,
# a listener that disappears, garbage at every port), watched from outside by
# build/release/tools/bench_soak. Results: OUT/summary.txt (tables), OUT/summary.json,
# OUT/samples.csv, OUT/ipsd.log. Exit 0 if every check passed.
# Usage: tools/soak.sh SECONDS [OUT] [PERIOD]    (build first: ipsd ips_tool ips_v4l2_emu bench_soak)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${IPS_BUILD:-$root/build/release}
seconds=${1:?usage: tools/soak.sh SECONDS [OUT] [PERIOD]}
out=${2:-$root/soak-$(date +%Y%m%d-%H%M%S)}
period=${3:-30}
for f in ipsd ips tests/libips_v4l2_emu.so tools/bench_soak; do
  [[ -e $build/$f ]] || { echo "soak.sh: $build/$f missing: cmake --build $build --target ipsd ips_tool ips_v4l2_emu bench_soak" >&2; exit 2; }
done
mkdir -p "$out"
echo "soak.sh: $seconds s, a fault every $period s, results in $out (started $(date -Is), $(uptime))"
exec "$build/tools/bench_soak" --seconds "$seconds" --period "$period" --out "$out" \
  --ipsd "$build/ipsd" --ips "$build/ips" --emu "$build/tests/libips_v4l2_emu.so"
