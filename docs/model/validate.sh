#!/bin/sh
# The validation sweep that chose the default model's options (alpha, normalisation), on the
# training subjects only (2, 5, 7): every 3rd clip (sorted) is the validation part.
#   docs/model/validate.sh [build/bin/kata] [../shared/data/cmu] [workdir]
set -e
KATA=${1:-build/bin/kata}
DATA=${2:-../shared/data/cmu}
W=${3:-/tmp/kata-validate}
mkdir -p $W
S="--data $DATA --subjects 2,5,7 --split-every 3"
$KATA pairs $S --split-part train --protocol cross-body --per-class 3000 --seed 11 --out $W/cb_tr3k.csv
$KATA pairs $S --split-part val --protocol cross-body --per-class 500 --seed 12 --out $W/cb_val.csv
$KATA pairs $S --split-part val --protocol transition --per-class 500 --seed 12 --out $W/tr_val.csv
$KATA train $S --split-part train --pairs $W/cb_tr3k.csv --out $W/s3_mm.kata --alpha 1 --sweep-alpha 10,100,1000
$KATA train $S --split-part train --pairs $W/cb_tr3k.csv --out $W/s3_bb.kata --normalisation block-balanced \
  --alpha 1 --sweep-alpha 10,100,1000
$KATA train $S --split-part train --pairs $W/cb_tr3k.csv --out $W/s4_mm.kata --alpha 10000 --sweep-alpha 100000,1000000
$KATA eval --data $DATA --pairs $W/cb_val.csv --train-pairs $W/cb_tr3k.csv --no-plot \
  --model $W/s3_mm.kata --model $W/s3_mm_a10_r50.kata --model $W/s3_mm_a100_r50.kata --model $W/s3_mm_a1000_r50.kata \
  --model $W/s4_mm.kata --model $W/s4_mm_a100000_r50.kata --model $W/s4_mm_a1e+06_r50.kata \
  --model $W/s3_bb.kata --model $W/s3_bb_a10_r50.kata --model $W/s3_bb_a100_r50.kata --model $W/s3_bb_a1000_r50.kata
