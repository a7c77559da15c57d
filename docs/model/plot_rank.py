#!/usr/bin/python3
"""Precision against rank r (like the paper's Fig. 4) from a `kata eval` CSV whose models are
labelled r<rank>.  Usage: plot_rank.py eval.csv out.png [title]"""
import csv
import sys

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt

rows = [r for r in csv.DictReader(open(sys.argv[1])) if r['method'] == 'GPD+RDSR' and r['model'].startswith('r')]
pts = sorted((int(r['model'][1:]), float(r['precision'])) for r in rows)
base = {r['method']: float(r['precision']) for r in csv.DictReader(open(sys.argv[1])) if r['model'] in ('-', 'r50')}
fig, ax = plt.subplots(figsize=(5.5, 3.8))
ax.plot([p[0] for p in pts], [p[1] for p in pts], 'o-', label='GPD+RDSR')
for name, style in (('JCD', ':'), ('GPD+L2', '--'), ("RDSR N'=0 (eq. 46)", '-.')):
    if name in base:
        ax.axhline(base[name], linestyle=style, color='gray', linewidth=1)
        ax.text(pts[-1][0], base[name], ' ' + name, fontsize=7, va='center')
ax.set_xlabel('rank r')
ax.set_ylabel('precision (eq. 37)')
ax.set_title(sys.argv[3] if len(sys.argv) > 3 else 'precision vs rank')
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
