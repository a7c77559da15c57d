#!/bin/sh
# Leave-one-subject-out validation on the training subjects 2, 5, 7 (the held-out test subjects
# 1 and 9 are never used here): for each fold, train on two subjects' clips and cross-body pairs,
# validate on the third subject's cross-body pairs.
#   docs/model/validate_loso.sh [build/bin/kata] [../shared/data/cmu] [workdir] [normalisation] [pca]
set -e
KATA=${1:-build/bin/kata}
DATA=${2:-../shared/data/cmu}
W=${3:-/tmp/kata-loso}
NORM=${4:-minmax}
PCA=${5:-0}
mkdir -p $W
for fold in "2,5 7" "2,7 5" "5,7 2"; do
  set -- $fold
  TR=$1; VA=$2; T=$W/$(echo $TR | tr , _)_${NORM}_pca$PCA
  [ -f $W/tr_$TR.csv ] || $KATA pairs --data $DATA --subjects $TR --protocol cross-body --per-class 3000 --seed 21 --out $W/tr_$TR.csv
  [ -f $W/va_$VA.csv ] || $KATA pairs --data $DATA --subjects $VA --protocol cross-body --per-class 500 --seed 22 --out $W/va_$VA.csv
  $KATA train --data $DATA --subjects $TR --pairs $W/tr_$TR.csv --normalisation $NORM --pca $PCA --out $T.kata \
    --alpha 1000000 --sweep-alpha 1,100,10000 > $T.log
  $KATA eval --data $DATA --pairs $W/va_$VA.csv --train-pairs $W/tr_$TR.csv --no-plot --out-dir $T-eval \
    --model $T.kata --label a1e6 --model ${T}_a1_r50.kata --label a1 --model ${T}_a100_r50.kata --label a100 \
    --model ${T}_a10000_r50.kata --label a1e4
done
