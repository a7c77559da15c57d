#!/usr/bin/env python3
"""Figures of docs/retarget/README.md from the .npy files `kata_retarget_report --out DIR` writes.

usage: python3 docs/retarget/plot_retarget.py DIR docs/retarget
  DIR/paper_original.npy     (22, 3)     Table I walking posture, metres
  DIR/paper_retargeted.npy   (5, 22, 3)  the same retargeted (same, spine +60%, arms +30%, legs -20%, all)
  DIR/paper_parents.npy      (22,)
  DIR/stream_02_10.npy       (frames, 3, 21, 3)  teacher, ghost, FK baseline per frame (CMU units)
  DIR/stream_parents.npy     (21,)
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

src, dst = sys.argv[1], sys.argv[2]


def side_axis(pose):
    """The horizontal direction of largest spread (the stride): a side view looks across it."""
    xz = pose[:, [0, 2]] - pose[:, [0, 2]].mean(axis=0)
    _, _, vt = np.linalg.svd(xz, full_matrices=False)
    return vt[0]


def draw(ax, pose, parents, axis, color, label=None, lw=2.0, ls="-"):
    h = pose[:, [0, 2]] @ axis
    h = h - h[0]
    y = pose[:, 1] - pose[:, 1].min()
    for j, p in enumerate(parents):
        if p >= 0:
            ax.plot([h[p], h[j]], [y[p], y[j]], color=color, lw=lw, ls=ls, label=label if j == 1 else None)
    ax.scatter(h, y, s=8, color=color)


original = np.load(f"{src}/paper_original.npy")
retargeted = np.load(f"{src}/paper_retargeted.npy")
parents = np.load(f"{src}/paper_parents.npy").astype(int)
titles = ["same skeleton", "spine +60%", "arms +30%", "legs -20%", "all three"]
axis = side_axis(original)
fig, axes = plt.subplots(1, 5, figsize=(16, 4.6), sharey=True)
for ax, pose, title in zip(axes, retargeted, titles):
    draw(ax, original, parents, axis, "0.65", "original (Table I)", lw=3.0)
    draw(ax, pose, parents, axis, "tab:red", "retargeted")
    ax.set_title(title)
    ax.set_aspect("equal")
    ax.set_xlabel("along the stride (m)")
axes[0].set_ylabel("height (m)")
axes[0].legend(loc="upper left", fontsize=8)
fig.suptitle("Walking posture (CMU 02_01, frame 60) on the paper's 22-joint Table I skeleton, retargeted "
             "(SPG optimum + exact bone lengths)")
fig.tight_layout()
fig.savefig(f"{dst}/paper_postures.png", dpi=90)

# A real pair: subject 2 washing (02_10) on subject 5's bones: teacher, ghost and FK baseline.
stream = np.load(f"{src}/stream_02_10.npy")
sp = np.load(f"{src}/stream_parents.npy").astype(int)
frames = [300, 900, 1500, 2100]
fig, axes = plt.subplots(1, len(frames), figsize=(14, 4.6), sharey=True)
for ax, f in zip(axes, frames):
    t, g, fk = stream[f]
    a = side_axis(t)
    draw(ax, t, sp, a, "0.65", "teacher (subject 2)", lw=3.0)
    draw(ax, fk, sp, a, "tab:blue", "FK baseline", lw=1.2, ls="--")
    draw(ax, g, sp, a, "tab:red", "ghost (subject 5 bones)")
    ax.set_title(f"02_10 frame {f + 1}")
    ax.set_aspect("equal")
axes[0].set_ylabel("height (CMU units, 5.64 cm)")
axes[0].legend(loc="upper left", fontsize=8)
fig.tight_layout()
fig.savefig(f"{dst}/cmu_02_10_on_05.png", dpi=90)
print("wrote", f"{dst}/paper_postures.png", f"{dst}/cmu_02_10_on_05.png")
