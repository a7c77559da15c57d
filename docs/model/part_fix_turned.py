#!/usr/bin/python3
"""The turned-joint side of the part-to-fix rules: the balance test's copies (3 s of
02_01, 05_18, 09_01; the ten joints of ../shared/tools/balance-table turned by +-30 and +-45 deg on every
frame after frame 0) scored against their own clip by `kata score` with the online alignment, written as
per-frame CSVs with the local-frame part offsets at the matched frame (part_fix.py's geometry), so that
part_fix_rules.py can replay a rule on the turned copies as it does on the real pairs.

    /usr/bin/python3 docs/model/part_fix_turned.py [build/bin/kata] [../shared/data/cmu] [models/default.kata] [whole]

With `whole`, the whole clips instead of the test's 3 s (balance-table's copies).

Prints the share of scoring frames naming the turned joint's part, per row, as the product's scorer
wrote it (the CSV's part_to_fix): compare with Balance.EveryJointCountsAlikeLeftAndRight's online block.
"""
import csv, os, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
KATA = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata"
DATA = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/cmu"
MODEL = sys.argv[3] if len(sys.argv) > 3 else "models/default.kata"
WHOLE = len(sys.argv) > 4 and sys.argv[4] == "whole"
sys.argv = [sys.argv[0], "measure", KATA, DATA, MODEL]
sys.path.insert(0, HERE)
import part_fix as P  # noqa: E402

BEND = os.path.join(os.path.dirname(os.path.abspath(DATA)), "..", "tools", "bend-joint")
CLIPS = ["02_01", "05_18", "09_01"]
FRAMES = 10 ** 9 if WHOLE else 361  # the test's kMaxFrames: frame 0 and 3 s at 120 fps
TURNS = [("LeftForeArm", "Y", 1), ("RightForeArm", "Y", 2), ("LeftArm", "Z", 1), ("RightArm", "Z", 2),
         ("LeftLeg", "X", 3), ("RightLeg", "X", 4), ("LeftUpLeg", "X", 3), ("RightUpLeg", "X", 4),
         ("Spine1", "X", 0), ("Neck1", "X", 0)]
ANGLES = [30, -30, 45, -45]
WORK = os.path.join(P.WORK, "turned-whole" if WHOLE else "turned")


def excerpt(clip):
    path = os.path.join(WORK, clip + ".bvh")
    if not os.path.exists(path):
        lines = open(os.path.join(DATA, clip + ".bvh")).read().splitlines()
        m = next(i for i, l in enumerate(lines) if l.strip().startswith("MOTION"))
        n = min(FRAMES, int(lines[m + 1].split()[1]))
        out = lines[:m + 1] + ["Frames: %d" % n, lines[m + 2]] + lines[m + 3:m + 3 + n]
        open(path, "w").write("\n".join(out) + "\n")
    return path


def features(path):
    npy = path[:-4] + ".npy"
    if not os.path.exists(npy):
        P.run("features", "--bvh", path, "--preset", "cmu", "--first-frame", "1", "--out", npy)
    return np.load(npy).astype(np.float64)


def copy(clip, joint, axis, deg):
    """One turned copy scored online: dict with t, ps, geo (frames x 5), total, shown, part."""
    src = excerpt(clip)
    bvh = os.path.join(WORK, "%s_%s_%d.bvh" % (clip, joint, deg))
    if not os.path.exists(bvh):
        subprocess.run([BEND, src, bvh, joint, str(deg), axis], check=True)
    out = os.path.join(WORK, "%s_%s_%d_%s.csv" % (clip, joint, deg, P.model_key()))
    if not os.path.exists(out):
        P.run("score", "--model", MODEL, "--teacher", src, "--student", bvh, "--preset", "cmu", "--first-frame", "1",
              "--out", out)
    rows = [r for r in csv.DictReader(l for l in open(out) if not l.startswith("#")) if r["state"] == "scoring"]
    a = np.array([int(r["frame"]) - 1 for r in rows])
    b = np.array([int(r["matched_teacher_frame"]) - 1 for r in rows])
    js, jt = P.local_joints(features(bvh)), P.local_joints(features(src))
    dist = np.linalg.norm(js[a] - jt[b], axis=2)
    geo = np.stack([dist[:, P.PART_JOINTS[p]].mean(1) for p in range(5)], 1)
    return dict(t=np.array([float(r["time"]) for r in rows]), total=np.array([float(r["score"]) for r in rows]),
                ps=np.array([[float(r[p + "_score"]) for p in P.PARTS] for r in rows]), geo=geo,
                shown=np.array([P.PARTS.index(r["part_to_fix"]) if r["part_to_fix"] in P.PARTS else -1 for r in rows]))


def load():
    os.makedirs(WORK, exist_ok=True)
    rows = []
    for clip in CLIPS:
        for joint, axis, part in TURNS:
            for deg in ANGLES:
                c = copy(clip, joint, axis, deg)
                c.update(clip=clip, joint=joint, deg=deg, part=part)
                rows.append(c)
    return rows


if __name__ == "__main__":
    for c in load():
        print("%s %-13s %4d %.2f" % (c["clip"], c["joint"], c["deg"], np.mean(c["shown"] == c["part"])))
