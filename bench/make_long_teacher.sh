#!/usr/bin/env bash
# Writes a long teacher: the BVH clip $1 with its frames repeated $2 times, to $3.
# The figures in docs/model/alignment.md use CMU clips repeated 16 and 64 times; the files run to
# hundreds of MB, so they are made on demand, never committed.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 CLIP.bvh TIMES OUT.bvh" >&2; exit 2; }
clip=$1 times=$2 out=$3
frames=$(awk '/^Frames:/ {print $2; exit}' "$clip")
motion=$(grep -n '^Frame Time:' "$clip" | head -1 | cut -d: -f1)
{
  sed -n "1,$((motion - 2))p" "$clip"
  echo "Frames: $((frames * times))"
  sed -n "${motion}p" "$clip"
  for ((i = 0; i < times; ++i)); do tail -n "+$((motion + 1))" "$clip" | head -n "$frames"; done
} > "$out"
