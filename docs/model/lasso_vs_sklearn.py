#!/usr/bin/python3
"""Side-by-side of kata's sparse-coding stage (eq. 16) and scikit-learn's Lasso on the same problems.

Input: the folder written by `kata train ... --lasso-compare DIR` (X.npy: d x N' normalised poses;
problems.csv: problem index i, gamma, kata's objective, support, KKT violation, duality gap, time).
Problem i: min_a |x_i - X_{-i} a|^2 + gamma |a|_1 (a_ii = 0 by dropping column i).
scikit-learn minimises (1 / (2 n)) |y - X w|^2 + alpha |w|_1 with n = d samples, so
alpha = gamma / (2 d) and its objective times 2 d is ours. Both get the precomputed Gram matrix.
Needs Debian's python3-sklearn.  Usage: lasso_vs_sklearn.py DIR [--out report.md]
"""
import csv
import sys
import time

import numpy as np
from sklearn.linear_model import Lasso

folder = sys.argv[1]
out = sys.argv[sys.argv.index('--out') + 1] if '--out' in sys.argv else None
X = np.load(folder + '/X.npy')  # d x N
d, n = X.shape
G = X.T @ X
rows = list(csv.DictReader(open(folder + '/problems.csv')))
lines = ['| problem | support kata / sklearn | objective kata | objective sklearn | rel. diff | kata s | sklearn s | ratio |',
         '|---|---|---|---|---|---|---|---|']
worst, t_k, t_s = 0.0, 0.0, 0.0
for r in rows:
    i, gamma = int(r['index']), float(r['gamma'])
    keep = np.r_[0:i, i + 1:n]
    Xi, y = X[:, keep], X[:, i]
    Gi = G[np.ix_(keep, keep)]
    # tol=1e-12 so that both reach the same optimum; scikit-learn is faster with its default tol.
    model = Lasso(alpha=gamma / (2 * d), fit_intercept=False, precompute=Gi, tol=1e-12, max_iter=100000)
    t0 = time.perf_counter()
    model.fit(Xi, y)
    ts = time.perf_counter() - t0
    w = model.coef_
    res = y - Xi @ w
    obj = res @ res + gamma * np.abs(w).sum()
    ok = float(r['objective'])
    rel = (obj - ok) / max(abs(ok), 1e-300)
    worst = max(worst, abs(rel))
    tk = float(r['seconds'])
    t_k += tk
    t_s += ts
    lines.append('| %d | %s / %d | %.12g | %.12g | %+.2e | %.4f | %.4f | %.0fx |' % (
        i, r['support'], int(np.count_nonzero(w)), ok, obj, rel, tk, ts, ts / max(tk, 1e-9)))
lines.append('')
lines.append('max |relative objective difference| = %.2e (rel. diff = (sklearn - kata) / kata: positive = scikit-learn's objective is higher); '
             'total time kata %.3f s, scikit-learn %.3f s (x%.0f), N = %d, d = %d' % (worst, t_k, t_s, t_s / max(t_k, 1e-9), n, d))
text = '\n'.join(lines)
print(text)
if out:
    open(out, 'w').write(text + '\n')
