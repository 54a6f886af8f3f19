#!/usr/bin/env bash
# Fuzzes every target in fuzz/ for SECONDS each (default 600), two at a time under nice:
#   tools/fuzz.sh [SECONDS]
# Builds build/fuzz with clang-14 (libFuzzer + ASan + UBSan). New corpus entries stay in a work
# folder (FUZZ_WORK, default build/fuzz/run), never in the repository; a crash, leak, timeout
# or out-of-memory input is copied to tests/fuzz/<target>/ (a regression input: fix it, keep
# it). Prints per target the executions, coverage (cov/ft from libFuzzer's final stats) and
# findings. Environment: FUZZ_TARGETS="config jpeg" (a subset), FUZZ_PARALLEL (2), FUZZ_NICE (10).
set -euo pipefail
SECONDS_EACH=${1:-600}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${FUZZ_BUILD:-$ROOT/build/fuzz}
WORK=${FUZZ_WORK:-$BUILD/run}
PARALLEL=${FUZZ_PARALLEL:-2}
NICE=${FUZZ_NICE:-10}

if [[ ! -f $BUILD/CMakeCache.txt ]]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Fuzz \
    -DCMAKE_CXX_FLAGS_FUZZ="-O1 -gline-tables-only" -DCMAKE_C_FLAGS_FUZZ="-O1 -gline-tables-only" \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DIPS_FUZZ=ON \
    -DIPS_BUILD_TESTS=OFF -DIPS_BUILD_BENCHMARKS=OFF \
    -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache >/dev/null
fi
ALL=$(cd "$ROOT/fuzz" && ls fuzz_*.cpp | sed 's/^fuzz_//; s/\.cpp$//')
TARGETS=${FUZZ_TARGETS:-$ALL}
cmake --build "$BUILD" -j2 --target $(for t in $TARGETS; do echo "fuzz_$t"; done)

run_one() {  # target
  local t=$1 dir=$WORK/$1
  mkdir -p "$dir/corpus" "$dir/artifacts"
  local dirs=("$dir/corpus" "$ROOT/fuzz/corpus/$t")
  [[ -d $ROOT/tests/fuzz/$t ]] && dirs+=("$ROOT/tests/fuzz/$t")
  local dict=()
  [[ -f $ROOT/fuzz/dict/$t.dict ]] && dict=("-dict=$ROOT/fuzz/dict/$t.dict")
  echo "start: $(uptime)" >"$dir/log"
  nice -n "$NICE" "$BUILD/fuzz/fuzz_$t" -max_total_time="$SECONDS_EACH" -timeout=20 -rss_limit_mb=2560 \
    -print_final_stats=1 "${dict[@]}" -artifact_prefix="$dir/artifacts/" "${dirs[@]}" >>"$dir/log" 2>&1 || true
  echo "end: $(uptime)" >>"$dir/log"
}
export -f run_one
export ROOT BUILD WORK SECONDS_EACH NICE
echo "fuzzing $(echo $TARGETS | wc -w) targets for ${SECONDS_EACH} s each, $PARALLEL at a time (logs in $WORK/<target>/log)"
echo "load at start: $(uptime)"
printf '%s\n' $TARGETS | xargs -P "$PARALLEL" -I{} bash -c 'run_one {}'
echo "load at end:   $(uptime)"

printf '\n%-14s %14s %8s %8s %8s %9s %s\n' target executions exec/s cov ft corpus findings
status=0
for t in $TARGETS; do
  dir=$WORK/$t
  execs=$( (grep -o 'stat::number_of_executed_units: *[0-9]*' "$dir/log" || true) | grep -o '[0-9]*$' | tail -1)
  last=$( (grep -E '^#[0-9]+' "$dir/log" || true) | grep -o 'cov: [0-9]* ft: [0-9]* corp: [0-9]*' | tail -1)
  cov=$(echo "$last" | awk '{print $2}'); ft=$(echo "$last" | awk '{print $4}'); corp=$(echo "$last" | awk '{print $6}')
  findings=()
  for f in "$dir"/artifacts/{crash,leak,timeout,oom,slow-unit}-*; do
    [[ -e $f ]] || continue
    mkdir -p "$ROOT/tests/fuzz/$t"
    cp "$f" "$ROOT/tests/fuzz/$t/"
    findings+=("tests/fuzz/$t/$(basename "$f")")
    status=1
  done
  rate=$( (grep -o 'stat::average_exec_per_sec: *[0-9]*' "$dir/log" || true) | grep -o '[0-9]*$' | tail -1)
  printf '%-14s %14s %8s %8s %8s %9s %s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "${findings[*]:-none}"
done
exit $status
