import csv, matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt
rows = list(csv.DictReader(open('docs/model/eval-transition/eval.csv')))
labels = [r['method'] + ('' if r['model'] == '-' else '\n' + r['model']) for r in rows]
vals = [float(r['precision']) for r in rows]
fig, ax = plt.subplots(figsize=(max(6, 0.9 * len(rows)), 4.5))
ax.bar(range(len(rows)), vals, color=['#888' if r['model'] == '-' else '#3a7' for r in rows])
ax.set_xticks(range(len(rows)))
ax.set_xticklabels(labels, rotation=60, ha='right', fontsize=7)
ax.set_ylim(0.4, 1.0)
ax.set_ylabel('precision (eq. 37)')
ax.set_title('transition (future agreement), test subjects 1 and 9')
for i, v in enumerate(vals): ax.text(i, v + 0.005, '%.3f' % v, ha='center', fontsize=7)
fig.tight_layout()
fig.savefig('docs/model/eval-transition/eval.png', dpi=110)
