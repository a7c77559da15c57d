#!/usr/bin/python3
"""The alignment figure of docs/model/alignment.md: the default lesson (teacher CMU 05_18, student
05_19 on subject 2's body) scored by kata score three ways: the re-localising online alignment,
the band-only online alignment (--relocate-time 0, the first behaviour) and the offline
subsequence DTW (--align dtw). Plots the matched teacher frame and the score of each student frame.

    /usr/bin/python3 docs/model/alignment/figure.py build/bin/kata
"""
import csv
import os
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

kata = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata"
here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(os.path.join(here, "..", "..", ".."))
runs = {"online, re-localising (default)": ["--align", "online"],
        "online, band only (--relocate-time 0)": ["--align", "online", "--relocate-time", "0"],
        "offline subsequence DTW (--align dtw)": ["--align", "dtw"]}
rows, means = {}, {}
with tempfile.TemporaryDirectory() as tmp:
    for name, extra in runs.items():
        out = os.path.join(tmp, "s.csv")
        r = subprocess.run([kata, "score", "--model", "models/default.kata", "--teacher", "data/cmu/05_18.bvh",
                            "--student", "data/cmu/05_19_on_02.bvh", "--preset", "cmu", "--first-frame", "1",
                            "--out", out] + extra, cwd=root, check=True, capture_output=True, text=True)
        means[name] = float(r.stdout.split("mean score ")[1].split()[0])
        rows[name] = list(csv.DictReader(open(out)))
fig, (a, b) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
for name, rs in rows.items():
    t = [float(r["time"]) for r in rs]
    a.plot(t, [float(r["matched_teacher_time"]) for r in rs], label=name, lw=1.4)
    b.plot(t, [float(r["score"]) for r in rs], label=f"{name}: mean {means[name]:.1f}", lw=0.9)
a.set_ylabel("matched teacher time (s)")
a.set_title("Default lesson: student 05_19 (last 60% of the routine) against teacher 05_18")
a.legend(fontsize=8)
b.set_ylabel("score (0-100)")
b.set_xlabel("student time (s)")
b.legend(fontsize=8, loc="lower right")
fig.tight_layout()
fig.savefig(os.path.join(here, "demo_alignment.png"), dpi=110)
for name in runs:
    print(f"{name}: mean score {means[name]:.1f}")
