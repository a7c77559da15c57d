#!/bin/sh
# The coaching model's stored threshold delta*, chosen by leave-one-subject-out on the training
# subjects 2, 5, 7 only (the test subjects 1 and 9 are never used): per fold, train on two
# subjects with the shipped options, and take the ratio of the best threshold on the third
# subject's cross-body pairs (eq. 37) to the fold model's own delta* (best on its training pairs).
# New bodies sit farther apart than training bodies; the median ratio scales the shipped delta*.
#   docs/model/threshold_loso.sh [build/bin/kata] [../shared/data/cmu] [workdir]
# Prints one line per fold and the median ratio; regenerate.sh applies it (kata calibrate --delta-star).
set -e
KATA=${1:-build/bin/kata}
DATA=${2:-../shared/data/cmu}
W=${3:-/tmp/kata-threshold-loso}
mkdir -p $W
for fold in "2,5 7" "2,7 5" "5,7 2"; do
  set -- $fold
  TR=$1; VA=$2; T=$W/$(echo $TR | tr , _)
  [ -f $W/tr_$TR.csv ] || $KATA pairs --data $DATA --subjects $TR --protocol cross-body --per-class 3000 --seed 21 --out $W/tr_$TR.csv > /dev/null
  [ -f $W/va_$VA.csv ] || $KATA pairs --data $DATA --subjects $VA --protocol cross-body --per-class 500 --seed 22 --out $W/va_$VA.csv > /dev/null
  [ -f $T.kata ] || $KATA train --data $DATA --subjects $TR --pairs $W/tr_$TR.csv --unlabeled 5000 --seed 1 --rank 50 \
    --alpha 10000 --pca 400 --gamma 0.05 --normalisation minmax --out $T.kata > $T.log
  $KATA eval --data $DATA --pairs $W/va_$VA.csv --train-pairs $W/tr_$TR.csv --no-plot --out-dir $T-eval \
    --model $T.kata --label fold > /dev/null
  awk -F, -v tr=$TR -v va=$VA '$1=="GPD+RDSR" {best=$5; pb=$4} $1=="GPD+RDSR @delta*" {own=$5; po=$4}
    END {printf "fold train %s val %s: best %.6g (precision %.3f), own delta* %.6g (precision %.3f), ratio %.4f\n", tr, va, best, pb, own, po, best/own}' \
    $T-eval/eval.csv
done | tee $W/folds.txt
awk '{print $NF}' $W/folds.txt | sort -g | awk '{r[NR]=$1} END {printf "median ratio %.4f\n", r[int((NR+1)/2)]}'
