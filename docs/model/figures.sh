#!/bin/sh
# Figures next to the default model: precision vs rank (Fig. 4), vs N' (Fig. 7), and the
# sparse-coding side-by-side with scikit-learn. Run after regenerate.sh, same arguments.
set -e
KATA=${1:-build/bin/kata}
DATA=${2:-../shared/data/cmu}
P=docs/model/pairs
V=docs/model/variants
M="--data $DATA --subjects 2,5,7 --pairs $P/train-cross-body.csv --seed 1 --alpha 10000 --pca 400 --gamma 0.05"
# Rank (the variants written by regenerate.sh) on the held-out cross-body pairs.
$KATA eval --data $DATA --pairs $P/test-cross-body.csv --train-pairs $P/train-cross-body.csv --no-plot \
  --out-dir docs/model/eval-rank --model $V/default_a10000_r10.kata --label r10 --model $V/default_a10000_r20.kata --label r20 \
  --model $V/default_a10000_r30.kata --label r30 --model models/default.kata --label r50 \
  --model $V/default_a10000_r80.kata --label r80 --model $V/default_a10000_r120.kata --label r120
/usr/bin/python3 docs/model/plot_rank.py docs/model/eval-rank/eval.csv docs/model/eval-rank/rank.png \
  "GPD+RDSR vs rank (cross-body, test subjects 1, 9)"
# N' (unlabeled poses); N' = 0 is eq. 46 (the "RDSR N'=0" row of every eval).
for N in 500 1000 2000 10000; do
  $KATA train $M --unlabeled $N --out /tmp/kata_n$N.kata > /tmp/kata_n$N.log
done
$KATA eval --data $DATA --pairs $P/test-cross-body.csv --train-pairs $P/train-cross-body.csv --no-plot \
  --out-dir docs/model/eval-unlabeled --model /tmp/kata_n500.kata --label n500 --model /tmp/kata_n1000.kata --label n1000 \
  --model /tmp/kata_n2000.kata --label n2000 --model models/default.kata --label n5000 --model /tmp/kata_n10000.kata --label n10000
/usr/bin/python3 - <<'PY'
import csv, matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt
rows = list(csv.DictReader(open('docs/model/eval-unlabeled/eval.csv')))
pts = sorted((int(r['model'][1:]), float(r['precision'])) for r in rows if r['method'] == 'GPD+RDSR')
zero = [float(r['precision']) for r in rows if r['method'].startswith("RDSR N'=0")][0]
fig, ax = plt.subplots(figsize=(5.5, 3.8))
ax.plot([0] + [p[0] for p in pts], [zero] + [p[1] for p in pts], 'o-')
ax.set_xlabel("N' (unlabeled poses; 0 = eq. 46)"); ax.set_ylabel('precision (eq. 37)')
ax.set_title("GPD+RDSR vs N' (cross-body, test subjects 1, 9)")
fig.tight_layout(); fig.savefig('docs/model/eval-unlabeled/unlabeled.png', dpi=110)
PY
# Sparse coding vs scikit-learn (Debian python3-sklearn) on 20 problems of the N' = 5000 set.
$KATA train $M --unlabeled 5000 --out /tmp/kata_lasso.kata --lasso-compare /tmp/kata-lasso > /tmp/kata_lasso.log
/usr/bin/python3 docs/model/lasso_vs_sklearn.py /tmp/kata-lasso --out docs/model/lasso_vs_sklearn.md
