#!/usr/bin/env bash
# The live figures in one go, base and new alternately (run it in a quiet window: nothing else on
# the machine). BASE_BIN and NEW_BIN are build/bin directories: each holds kata, kata-replay (or a
# kata whose `replay` is built in) and kata_bench. Every run's output goes to OUT_DIR, with the load
# average before and after it; summary.txt collects the lines the issue's targets are read from.
#   bench/live_figures.sh BASE_BIN NEW_BIN OUT_DIR [ROUNDS=2]
# Run from the repository's root (kata replay reads data/cmu and models/default.kata from there).
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,7p' "$0"; exit 2; }
base=$1 new=$2 out=$3 rounds=${4:-2}
mkdir -p "$out"
run() {  # name bin-dir args...
  local name=$1 dir=$2
  shift 2
  { echo "# $name: $*"; echo "# load before: $(cat /proc/loadavg)"; } > "$out/$name.txt"
  "$dir/kata" "$@" >> "$out/$name.txt" 2>&1 || echo "# exit $?" >> "$out/$name.txt"
  echo "# load after: $(cat /proc/loadavg)" >> "$out/$name.txt"
}
bench() {  # name bin-dir
  local name=$1 dir=$2
  { echo "# load before: $(cat /proc/loadavg)"; } > "$out/$name.txt"
  "$dir/kata_bench" --benchmark_filter='BM_PipelinePushPaced/' --benchmark_repetitions=3 \
    --benchmark_report_aggregates_only=true >> "$out/$name.txt" 2>&1
  echo "# load after: $(cat /proc/loadavg)" >> "$out/$name.txt"
}
for k in $(seq 1 "$rounds"); do
  for side in base new; do
    dir=$base
    [ "$side" = new ] && dir=$new
    # Target 1: the most streams at 120 Hz with p99 <= 2 ms through the ingest.
    run "${side}_findmax_$k" "$dir" replay --ingest --find-max --streams 16 --seconds 5 --p99-bound-us 2000
    # Target 2: the runtime's own CPU per frame at 64 streams x 120 Hz through the ingest.
    run "${side}_ingest64_$k" "$dir" replay --ingest --streams 64 --seconds 8
    # Target 3: the in-process push at 64 streams, p99 against the burst bound.
    run "${side}_push64_$k" "$dir" replay --streams 64 --seconds 8
    # Target 5: a frame after a 120 Hz sleep against a hot one.
    bench "${side}_paced_$k" "$dir"
  done
done
{
  echo "load at the end: $(cat /proc/loadavg)"
  for f in "$out"/*.txt; do
    [ "$(basename "$f")" = summary.txt ] && continue
    echo "== $(basename "$f" .txt)"
    grep -E "^streams|find-max:|CPU per frame|by stage|bare ZeroMQ CPU|PushPaced.*median|load" "$f" || true
  done
} > "$out/summary.txt"
echo "live_figures: $out/summary.txt"
# Target 4, the soak at the largest passing count (10 minutes), is separate:
#   build/bin/kata replay --ingest --soak --streams N --seconds 600 --window 10 --judge-windows 6
