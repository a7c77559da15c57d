#!/usr/bin/env bash
# Side-by-side figures: two kata_bench binaries (say, one built from an older commit in its own
# worktree and one from main) run alternately, twice, with the per-frame benchmarks of the live path
# (and the scoring ones again on the AVX2 kernels), then the paced pushes of the second binary three
# times. CPU-time medians of 5 repetitions, as JSON in OUT_DIR with the load average before and after
# each run; run it on a machine with nothing else running (docs/performance.md, "Final figures").
#   bench/side_by_side.sh BASE_KATA_BENCH NEW_KATA_BENCH OUT_DIR
set -euo pipefail
[ $# -eq 3 ] || { sed -n '2,7p' "$0"; exit 2; }
base=$1 new=$2 out=$3
mkdir -p "$out"
frame='BM_GpdFrame/dispatch$|Metric_EigenWtxNative$|Metric_ScorePose$|Metric_ScoreBatch/8$|BM_Retarget/cmu21_warm$|BM_PipelinePush$|BM_StreamFeatures_Backward$'
score='Metric_EigenWtxNative$|Metric_ScorePose$|Metric_ScoreBatch/8$'
paced='BM_PipelinePushPaced/|BM_PipelinePushPacedLesson/.*whole_section:0'
run() {  # name binary filter [VAR=value ...]
  local name=$1 bin=$2 filter=$3
  shift 3
  uptime > "$out/$name.uptime"
  env "$@" "$bin" --benchmark_filter="$filter" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
    --benchmark_format=json > "$out/$name.json"
  uptime >> "$out/$name.uptime"
}
for k in 1 2; do
  run "base_$k" "$base" "$frame"
  run "new_$k" "$new" "$frame"
  run "base_avx2_$k" "$base" "$score" KATA_NO_AVX512=1
  run "new_avx2_$k" "$new" "$score" KATA_NO_AVX512=1
done
for k in 1 2 3; do run "new_paced_$k" "$new" "$paced"; done
echo "side_by_side: $out"
