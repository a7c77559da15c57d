#!/usr/bin/python3
"""The coaching pairs (calibrate.py's 28: same motion by another subject, different motions) with
the student read as MediaPipe world landmarks (bvh_landmarks.py, the layout's One-Euro smoothing on,
as `kata score` and a webcam lesson read them) and as its BVH, each against the BVH teacher with
`kata score`'s online alignment: mean total over the scoring frames per pair, then the summary the
coach's targets read (same motion: mean and lowest; different motions: mean and highest). Give two
kata binaries to compare them (e.g. before and after a change); every figure is printed per binary.

    /usr/bin/python3 docs/model/landmark_pairs.py CMU_DIR MODEL KATA [KATA...]

Work files in build/landmark-pairs (not kept).
"""
import csv, os, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA, MODEL, KATAS = sys.argv[1], sys.argv[2], sys.argv[3:]
sys.path.insert(0, HERE)
sys.argv = sys.argv[:1]
from bvh_landmarks import mediapipe  # noqa: E402
from calibrate import PAIRS, MOTION  # noqa: E402
WORK = os.path.join("build", "landmark-pairs")


def score(kata, teacher, student, tag):
    out = os.path.join(WORK, tag + ".csv")
    args = [kata, "score", "--model", MODEL, "--teacher", teacher, "--teacher-layout", "cmu", "--student", student,
            "--first-frame", "1", "--out", out]
    args += ["--student-layout", "mediapipe", "--fps", "120"] if student.endswith(".npy") else ["--student-layout", "cmu"]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    rows = [r for r in csv.DictReader(l for l in open(out) if not l.startswith("#")) if r["state"] == "scoring"]
    return float(np.mean([float(r["score"]) for r in rows]))


def main():
    os.makedirs(WORK, exist_ok=True)
    heads = ["teacher", "student", "same"]
    for k in range(len(KATAS)):
        heads += ["BVH (%d)" % (k + 1), "landmarks (%d)" % (k + 1)]
    print("| " + " | ".join(heads) + " |")
    print("|" + "---|" * len(heads))
    got = {}
    for t, s in PAIRS:
        npy = os.path.join(WORK, s + ".npy")
        if not os.path.exists(npy):
            np.save(npy, mediapipe(os.path.join(DATA, s + ".bvh"))[0])
        same = MOTION[t] == MOTION[s]
        row = [t, s, "yes" if same else "no"]
        for k, kata in enumerate(KATAS):
            b = score(kata, os.path.join(DATA, t + ".bvh"), os.path.join(DATA, s + ".bvh"), "%s_%s_bvh%d" % (t, s, k))
            m = score(kata, os.path.join(DATA, t + ".bvh"), npy, "%s_%s_mp%d" % (t, s, k))
            got.setdefault((k, same), []).append((b, m))
            row += ["%.1f" % b, "%.1f" % m]
        print("| " + " | ".join(row) + " |", flush=True)
    print()
    for k, kata in enumerate(KATAS):
        for same in (True, False):
            v = np.array(got[(k, same)])
            what = "same motion (%d pairs): mean / lowest" % len(v) if same else \
                "different motions (%d pairs): mean / highest" % len(v)
            pick = np.min if same else np.max
            print("(%d) %s: %s BVH %.1f / %.1f, landmarks %.1f / %.1f" % (
                k + 1, kata, what, v[:, 0].mean(), pick(v[:, 0]), v[:, 1].mean(), pick(v[:, 1])))


if __name__ == "__main__":
    main()
