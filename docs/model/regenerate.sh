#!/bin/sh
# Regenerates models/default.kata (coaching), models/transition.kata, models/transition-static.kata and their evaluation reports (docs/model/).
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
# The stored threshold delta*: the training-pair delta* scaled by the median ratio (best threshold
# on a left-out training subject / the fold model's own delta*) of threshold_loso.sh (subjects 2, 5, 7).
RATIO=$(docs/model/threshold_loso.sh $KATA $DATA | sed -n 's/^median ratio //p')
DELTA=$($KATA model-info models/default.kata | awk -v r=$RATIO '/^delta\*:/ {printf "%.6g", $2 * r}')
$KATA calibrate --model models/default.kata --out models/default.kata --delta-star $DELTA
# The score map (total and per part), fitted on real cross-subject clip pairs, chosen by
# leave-one-subject-out (calibrate.py; report in eval-calibration/calibration.md).
/usr/bin/python3 docs/model/calibrate.py $KATA $DATA models/default.kata docs/model/eval-calibration
# The part maps on the joint-position part distances (one map on each part's distance
# put in body heights of joint displacement; replaces calibrate.py's part maps, keeps its total),
# then the part to fix against local-frame geometry on real pairs of different subjects (report
# in eval-part-fix/part_fix.md).
/usr/bin/python3 docs/model/part_fix.py fit $KATA $DATA models/default.kata
# The coaching total: total = min(model map, worst part's joint-angle score). The model
# map becomes the gate that keeps another motion low (d50 0.085, slope 10, good 92; coaching.py
# says why), then the totals on calibrate.py's real pairs (eval-calibration/coaching.md). Runs
# before part_fix.py measure: the part to fix is gated by good_score.
/usr/bin/python3 docs/model/coaching.py $KATA $DATA models/default.kata docs/model/eval-calibration
/usr/bin/python3 docs/model/part_fix.py measure $KATA $DATA models/default.kata docs/model/eval-part-fix
# The transition model (docs/model/transition.md): the joint form (kata train --method
# joint-form: one quadratic form per axis on each joint's position, velocity and acceleration
# differences, fitted to the labels by logistic regression), on within-subject pairs of the independent
# protocol from each training subject (the files transition_protocols.sh also uses): the best
# leave-one-subject-out mean under both protocols. No calibration stored: the default map. Then
# run transition_protocols.sh for its held-out figures.
TP=docs/model/eval-transition-protocols/pairs
mkdir -p $TP
for s in 2 5 7; do
  [ -f $TP/train-transition-uniform-$s.csv ] || $KATA pairs --data $DATA --subjects $s --protocol transition-uniform \
    --per-class 1000 --seed 1 --max-draws 5000000 --out $TP/train-transition-uniform-$s.csv > $TP/train-transition-uniform-$s.csv.log
done
$KATA train --data $DATA --subjects 2,5,7 --method joint-form --form-terms p,v,a --pairs $TP/train-transition-uniform-2.csv \
  --pairs $TP/train-transition-uniform-5.csv --pairs $TP/train-transition-uniform-7.csv --out models/transition.kata \
  | tee docs/model/train-transition.log
# The static transition model (docs/model/transition.md, recipe `old`: RDSR with the coaching
# model's options on the project's transition pairs of subjects 2, 5, 7): for candidates between
# clips of different motions, where static pose features tell the motions apart.
$KATA train --data $DATA --subjects 2,5,7 --pairs $P/train-transition.csv --unlabeled 5000 --seed 1 --rank 50 \
  --alpha 10000 --pca 400 --gamma 0.05 --normalisation minmax --out models/transition-static.kata \
  | tee docs/model/train-transition-static.log
mkdir -p docs/model/eval-transition-model
$KATA eval --data $DATA --pairs $P/test-transition.csv --train-pairs $P/train-transition.csv \
  --model models/transition.kata --label transition --title "transition (future agreement), test subjects 1 and 9" \
  --out-dir docs/model/eval-transition-model | tee docs/model/eval-transition-model/eval.log
/usr/bin/python3 docs/model/plot_eval.py docs/model/eval-transition-model "transition model, test subjects 1 and 9"
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
