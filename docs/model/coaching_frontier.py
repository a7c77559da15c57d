#!/usr/bin/python3
"""The trade of the coaching total's maps (the same-motion target against the 45-degree catch): same motion by
another subject >= 70, different motions <= 20, a 45-degree turn <= 50. Recomputes the total of
every scoring frame for other maps from one `kata score` run per pair, without rebuilding:

    total = min(100 / (1 + (d / d50)^dk), min_p 100 / (1 + (angle_p / a50)^ak))

d is the CSV's `distance`; each part's angle is recovered from its `*_score` column by inverting the
shipped map (kAngle50 40, slope 5; checked: the shipped maps reproduce the CSV's total to 1e-4). The
online alignment does not read the maps (its re-match ranks by the trimmed pose distance), so the
matched frames are the same for every map.

    /usr/bin/python3 docs/model/coaching_frontier.py [build/bin/kata] [../shared/data/cmu] [models/default.kata]

Pairs: calibrate.py's 28 (as coaching.py). Turned copies: 3 s (frame 0 and 360 frames) of 02_01,
05_18 and 09_01, the balance table's ten joints at +-30 and +-45 (../shared/tools/bend-joint), scored
by `kata score` with the online alignment. "45 over" counts the 60 copies at +-45 whose mean total is
over 50 (over 60 for the dance 05_18, as tests/metric/test_balance.cpp allows online). Work files go to
build/coaching-frontier (not kept).
"""
import csv, os, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
KATA = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata"
DATA = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/cmu"
MODEL = sys.argv[3] if len(sys.argv) > 3 else "models/default.kata"
WORK = os.path.join("build", "coaching-frontier")
sys.path.insert(0, HERE)
sys.argv = sys.argv[:1]
from calibrate import PAIRS, MOTION  # noqa: E402  (the labelled pairs of the map's fit)
from turned_clips import excerpt, turned  # noqa: E402

PARTS = ["torso_head", "left_arm", "right_arm", "left_leg", "right_leg"]
TURNS = [("LeftForeArm", "Y"), ("RightForeArm", "Y"), ("LeftArm", "Z"), ("RightArm", "Z"), ("LeftLeg", "X"),
         ("RightLeg", "X"), ("LeftUpLeg", "X"), ("RightUpLeg", "X"), ("Spine1", "X"), ("Neck1", "X")]
CLIPS = ["02_01", "05_18", "09_01"]
PAIRS_LR = [("LeftForeArm", "RightForeArm"), ("LeftArm", "RightArm"), ("LeftLeg", "RightLeg"), ("LeftUpLeg", "RightUpLeg")]


def score(teacher, student, out):
    if not os.path.exists(out):
        subprocess.run([KATA, "score", "--model", MODEL, "--teacher", teacher, "--student", student, "--preset", "cmu",
                        "--first-frame", "1", "--out", out], check=True, stdout=subprocess.DEVNULL)
    rows = [r for r in csv.DictReader(l for l in open(out) if not l.startswith("#")) if r["state"] == "scoring"]
    d = np.array([float(r["distance"]) for r in rows])
    ps = np.clip(np.array([[float(r[p + "_score"]) for p in PARTS] for r in rows]), 1e-6, 100.0)
    angle = 40.0 * np.maximum(100.0 / ps - 1.0, 0.0) ** (1 / 5.0)
    return d, angle, np.array([float(r["score"]) for r in rows])


def total(d, angle, a50, ak, d50, dk):
    return np.minimum(100.0 / (1.0 + (d / d50) ** dk), (100.0 / (1.0 + (angle / a50) ** ak)).min(1))


def main():
    os.makedirs(WORK, exist_ok=True)
    pairs = [("%s vs %s" % tuple(sorted((MOTION[t], MOTION[s]))),) +
             score(os.path.join(DATA, t + ".bvh"), os.path.join(DATA, s + ".bvh"), os.path.join(WORK, "%s_vs_%s.csv" % (t, s)))
             for t, s in PAIRS]
    copies = {}
    for c in CLIPS:
        for j, ax in TURNS:
            for deg in (30, -30, 45, -45):
                s = turned(DATA, WORK, c, j, deg, ax)
                copies[(c, j, deg)] = score(excerpt(DATA, WORK, c), s, s + ".csv")
    err = max(np.abs(total(d, a, 40, 5, 0.085, 10) - t).max() for _, d, a, t in pairs)
    print("shipped maps reproduce the CSV totals to %.1e\n" % err)
    print("| part map a50, slope | gate d50, slope | walk/walk | run/run | dance/dance | dance/walk | run/walk | dance/run "
          "| 45 over (of 60; highest) | left-right at 30, largest gap |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    grid = [(a, k, 0.085, 10) for a in (38, 40, 42, 44, 46, 48) for k in (4, 5, 6, 8)] + \
           [(40, 5, g, gk) for g in (0.06, 0.07) for gk in (6, 10)] + [(42, 8, g, 10) for g in (0.06, 0.07)]
    for a50, ak, d50, dk in grid:
        by = {}
        for k, d, a, _ in pairs:
            by.setdefault(k, []).append(total(d, a, a50, ak, d50, dk).mean())
        m = {k: np.mean(v) for k, v in by.items()}
        t = {k: total(v[0], v[1], a50, ak, d50, dk).mean() for k, v in copies.items()}
        over = [k for k in t if abs(k[2]) == 45 and t[k] > (60 if k[0] == "05_18" else 50)]
        lr = max(abs(t[(c, l, g)] - t[(c, r, g)]) for c in CLIPS for l, r in PAIRS_LR for g in (30, -30))
        print("| %g, %g | %g, %g | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %d (%.0f) | %.1f |" % (
            a50, ak, d50, dk, m["walk vs walk"], m["run vs run"], m["dance vs dance"], m["dance vs walk"],
            m["run vs walk"], m["dance vs run"], len(over), max(v for k, v in t.items() if abs(k[2]) == 45), lr))


if __name__ == "__main__":
    main()
