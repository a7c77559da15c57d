#!/bin/sh
# Regenerates models/default.kata and its evaluation report (docs/model/).
# Run from the repository root after building (build/bin/kata); DATA is the 59-clip CMU folder.
#   docs/model/regenerate.sh [build/bin/kata] [../shared/data/cmu]
set -e
KATA=${1:-build/bin/kata}
DATA=${2:-../shared/data/cmu}
P=docs/model/pairs
mkdir -p $P models docs/model/eval-cross-body docs/model/eval-transition
# Labeled pairs. Training: subjects 2, 5, 7. Test (held out): subjects 1, 9.
[ -f $P/train-cross-body.csv ] || $KATA pairs --data $DATA --subjects 2,5,7 --protocol cross-body --per-class 3000 --seed 1 --out $P/train-cross-body.csv
[ -f $P/train-transition.csv ] || $KATA pairs --data $DATA --subjects 2,5,7 --protocol transition --per-class 3000 --seed 1 --out $P/train-transition.csv
[ -f $P/test-cross-body.csv ] || $KATA pairs --data $DATA --subjects 1,9 --protocol cross-body --per-class 500 --seed 2 --out $P/test-cross-body.csv
[ -f $P/test-transition.csv ] || $KATA pairs --data $DATA --subjects 1,9 --protocol transition --per-class 500 --seed 2 --out $P/test-transition.csv
# The default model (PCA restriction and alpha chosen by leave-one-subject-out validation on
# subjects 2, 5, 7: validate_loso.sh, README.md), plus rank variants for the precision-vs-rank plot.
$KATA train --data $DATA --subjects 2,5,7 --pairs $P/train-cross-body.csv --unlabeled 5000 --seed 1 --rank 50 \
  --alpha 10000 --pca 400 --gamma 0.05 --normalisation minmax --out models/default.kata \
  --sweep-rank 10,20,30,80,120 | tee docs/model/train.log
mkdir -p docs/model/variants && mv models/default_a*_r*.kata docs/model/variants/
# Evaluation on the held-out subjects, both protocols (generated pair files are reused if present).
$KATA eval --data $DATA --pairs $P/test-cross-body.csv --train-pairs $P/train-cross-body.csv \
  --model models/default.kata --label default --title "cross-body (coaching), test subjects 1 and 9" \
  --out-dir docs/model/eval-cross-body | tee docs/model/eval-cross-body/eval.log
$KATA eval --data $DATA --pairs $P/test-transition.csv --train-pairs $P/train-transition.csv \
  --model models/default.kata --label default --title "transition (future agreement), test subjects 1 and 9" \
  --out-dir docs/model/eval-transition | tee docs/model/eval-transition/eval.log
# Retrieval (paper section 6): 200 k-means pose centres per subject, all five subjects pooled.
mkdir -p docs/model/eval-retrieval
$KATA eval --data $DATA --pairs $P/test-cross-body.csv --train-pairs $P/train-cross-body.csv \
  --model models/default.kata --label default --retrieval --clusters 200 --seed 1 \
  --out-dir docs/model/eval-retrieval | tee docs/model/eval-retrieval/eval.log
