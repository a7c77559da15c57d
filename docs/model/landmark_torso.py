#!/usr/bin/python3
"""Where a landmark student's 45-degree turn loses its catch: the same turned clip scored against the
unturned BVH teacher (kata score, online alignment) four ways, each adding one difference of the
MediaPipe path to the BVH one:

  bvh      the BVH student ("cmu" layout);
  gpd      its 16 GPD joints, exactly, as a "gpd" array (metres, no rest pose, no smoothing);
  torso    the same with Hip, Chest and Neck synthesised from the hip and shoulder points and the
           head as the "mediapipe" layout does (sdk/src/skeleton/layouts.cpp), still unsmoothed;
  mp       MediaPipe landmarks of the clip (bvh_landmarks.py) through the "mediapipe" layout (the
           synthesis, and its One-Euro smoothing).

    /usr/bin/python3 docs/model/landmark_torso.py [build/bin/kata] [CMU_DIR] [models/default.kata]

Work files in build/landmark-balance (the excerpts and turned copies of turned_clips.py, shared with
landmark_balance.py).
"""
import csv, os, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bvh_landmarks import METRES_PER_UNIT, mediapipe, positions  # noqa: E402
from turned_clips import excerpt, turned  # noqa: E402

KATA = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata"
DATA = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/cmu"
MODEL = sys.argv[3] if len(sys.argv) > 3 else "models/default.kata"
WORK = os.path.join("build", "landmark-balance")
ROWS = [("05_03", "LeftArm", 45, "Z"), ("05_03", "RightArm", 45, "Z"), ("05_03", "LeftLeg", 45, "X"),
        ("09_01", "LeftLeg", -45, "X"), ("02_01", "LeftForeArm", -45, "Y")]
# The "cmu" layout's GPD joints (Hip Chest Neck Head, the arms, the legs).
GPD = ["Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
       "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
# The "mediapipe" layout's synthesis (layouts.cpp): Hip and Chest on the hip-midpoint -> shoulder-
# midpoint line, the Hip set back by 0.07 along (hip line x that line) / |hip line|, the Neck half
# way from the Chest to the ears' midpoint (the BVH Head here: bvh_landmarks.py puts the ears at it
# +- 7 cm).
HIP_FRACTION, CHEST_FRACTION, HIP_OFFSET = 0.264, 0.868, -0.07


def gpd_joints(bvh, synthesise):
    w, _ = positions(bvh)
    p = np.stack([w[n] for n in GPD], 1) * METRES_PER_UNIT
    if synthesise:
        hips, shoulders = 0.5 * (p[:, 10] + p[:, 13]), 0.5 * (p[:, 4] + p[:, 7])
        lat = p[:, 10] - p[:, 13]
        p[:, 0] = (1 - HIP_FRACTION) * hips + HIP_FRACTION * shoulders + \
            HIP_OFFSET * np.cross(lat, shoulders - hips) / np.linalg.norm(lat, axis=1, keepdims=True)
        p[:, 1] = (1 - CHEST_FRACTION) * hips + CHEST_FRACTION * shoulders
        p[:, 2] = 0.5 * p[:, 1] + 0.5 * p[:, 3]
    return p.astype(np.float32)


def score(teacher, student, layout):
    out = student + ".csv"
    args = [KATA, "score", "--model", MODEL, "--teacher", teacher, "--teacher-layout", "cmu", "--student", student,
            "--student-layout", layout, "--first-frame", "1", "--out", out]
    if layout != "cmu":
        args += ["--fps", "120"]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    rows = [r for r in csv.DictReader(l for l in open(out) if not l.startswith("#")) if r["state"] == "scoring"]
    return np.mean([float(r["score"]) for r in rows])


def main():
    os.makedirs(WORK, exist_ok=True)
    print("| clip | joint | angle | bvh | gpd | torso | mp |")
    print("|---|---|---|---|---|---|---|")
    for c, j, deg, ax in ROWS:
        t = excerpt(DATA, WORK, c)
        s = turned(DATA, WORK, c, j, deg, ax, quiet=True)
        got = [score(t, s, "cmu")]
        for name, synth in (("gpd", False), ("torso", True)):
            path = s[:-4] + "." + name + ".npy"
            np.save(path, gpd_joints(s, synth))
            got.append(score(t, path, "gpd"))
        path = s[:-4] + ".npy"
        np.save(path, mediapipe(s)[0])
        got.append(score(t, path, "mediapipe"))
        print("| %s | %s | %+d | %s |" % (c, j, deg, " | ".join("%.1f" % g for g in got)))


if __name__ == "__main__":
    main()
