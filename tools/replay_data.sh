#!/usr/bin/env bash
# Regenerates the replay regression's input (tests/replay/data, docs/reliability.md): the
# committed frames (2 per camera, 960x540) rendered from tests/replay/data/scene.yaml, and the
# plane model fitted on simulated calibration pairs of the same scene. Run it only when the
# scene or the renderer changes on purpose; then regenerate the golden output:
#   IPS_REGENERATE_GOLDEN=1 build/release/tests/test_replay
# and commit both (review the golden diff: it is the daemon's published output).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
ips=${IPS:-$root/build/release/ips}
data=$root/tests/replay/data
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$ips" sim render --scene "$data/scene.yaml" --out "$tmp/frames" --frames 2 --fps 5
rm -rf "$data/frames"
for cam in red white; do
  mkdir -p "$data/frames/$cam"
  mv "$tmp/frames/${cam}_"*.jpg "$data/frames/$cam/"
done
"$ips" sim collect --scene "$data/scene.yaml" --camera red --camera white --points 25 --out "$tmp/pairs.csv"
"$ips" fit --data "$tmp/pairs.csv" --method plane --out "$data/model.json"
du -sh "$data"
