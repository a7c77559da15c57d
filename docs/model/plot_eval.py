#!/usr/bin/python3
"""The figures of a `kata eval` report, drawn from the CSV files it writes (kata eval itself only
writes CSV and Markdown). Usage (Debian's python3-matplotlib):
    /usr/bin/python3 docs/model/plot_eval.py EVAL_DIR [TITLE]
reads EVAL_DIR/eval.csv (and EVAL_DIR/retrieval.csv when present) and writes EVAL_DIR/eval.png
(and EVAL_DIR/retrieval.png)."""
import csv
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def plot_precision(eval_dir, title):
    rows = [r for r in csv.DictReader(open(os.path.join(eval_dir, "eval.csv")))
            if not r["method"].startswith("Retrieval")]
    labels = [r["method"] + ("" if r["model"] == "-" else "\n" + r["model"]) for r in rows]
    vals = [float(r["precision"]) for r in rows]
    fig, ax = plt.subplots(figsize=(max(6, 0.9 * len(rows)), 4.5))
    ax.bar(range(len(rows)), vals, color=["#888" if r["model"] == "-" else "#3a7" for r in rows])
    ax.set_xticks(range(len(rows)))
    ax.set_xticklabels(labels, rotation=60, ha="right", fontsize=7)
    ax.set_ylim(0.4, 1.0)
    ax.set_ylabel("precision (eq. 37)")
    ax.set_title(title)
    for i, v in enumerate(vals):
        ax.text(i, v + 0.005, "%.3f" % v, ha="center", fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(eval_dir, "eval.png"), dpi=110)


def plot_retrieval(eval_dir, title):
    path = os.path.join(eval_dir, "retrieval.csv")
    if not os.path.exists(path):
        return
    rows = list(csv.DictReader(open(path)))
    pools = sorted(set(r["pool"] for r in rows))
    fig, axes = plt.subplots(1, len(pools), figsize=(5.5 * len(pools), 4.2), squeeze=False)
    for ax, pool in zip(axes[0], pools):
        for r in [r for r in rows if r["pool"] == pool]:
            lab = r["method"] + ("" if r["model"] == "-" else " (" + r["model"] + ")")
            ax.plot([5, 10, 20], [float(r["p5"]), float(r["p10"]), float(r["p20"])], marker="o", label=lab)
        ax.set_xticks([5, 10, 20])
        ax.set_xlabel("scope s")
        ax.set_ylabel("precision (same motion type)")
        ax.set_title("retrieval, pool: " + pool)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(title + " - Section 6 retrieval", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(eval_dir, "retrieval.png"), dpi=110)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    d = sys.argv[1]
    t = sys.argv[2] if len(sys.argv) > 2 else os.path.basename(os.path.normpath(d))
    plot_precision(d, t)
    plot_retrieval(d, t)
