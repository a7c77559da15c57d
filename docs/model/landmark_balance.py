#!/usr/bin/python3
"""The balance table through MediaPipe landmarks as through BVH: one limb joint of a real clip
turned by +-45 degrees on every frame (../shared/tools/bend-joint), the copy scored against the
original BVH teacher by `kata score` with the online alignment (a) as a BVH student and (b) as
MediaPipe world landmarks made from it (bvh_landmarks.py, the converter of tests/api/test_anybody.cpp;
the layout's One-Euro smoothing on, as `kata score` and a webcam lesson read them). Mean total over
the scoring frames, and the share of them whose matched teacher frame is more than 3 frames off the
student's own (the landmark student's smoothing delays it about 4 frames: the share is measured
against its match when no joint is turned, the BVH student's against its own frame).

    /usr/bin/python3 docs/model/landmark_balance.py [build/bin/kata] [../shared/data/cmu] [models/default.kata] [clips...]

Default clips: every subject, 3 s (frame 0 and 360 frames) of 01_01 (jump), 02_01 and 07_01
(walk), 05_03 and 05_18 (dance), 09_01 (run). Work files in build/landmark-balance (REMATCH=S:
the landmark student re-matched within S seconds, `--rematch-time`; work files then in
build/landmark-balanceS).
"""
import csv, os, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bvh_landmarks import mediapipe  # noqa: E402
from turned_clips import excerpt, turned  # noqa: E402

KATA = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata"
DATA = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/cmu"
MODEL = sys.argv[3] if len(sys.argv) > 3 else "models/default.kata"
CLIPS = sys.argv[4:] or ["01_01", "02_01", "05_03", "07_01", "05_18", "09_01"]
WORK = os.path.join("build", "landmark-balance" + os.environ.get("REMATCH", ""))
TURNS = [("LeftForeArm", "Y"), ("RightForeArm", "Y"), ("LeftArm", "Z"), ("RightArm", "Z"), ("LeftLeg", "X"),
         ("RightLeg", "X"), ("LeftUpLeg", "X"), ("RightUpLeg", "X")]


def score(teacher, student):
    out = student + ".csv"
    args = [KATA, "score", "--model", MODEL, "--teacher", teacher, "--teacher-layout", "cmu", "--student", student,
            "--first-frame", "1", "--out", out]
    if student.endswith(".npy"):
        args += ["--student-layout", "mediapipe", "--fps", "120"]
        if os.environ.get("REMATCH"):  # an experiment: the landmark student's re-match reach, seconds
            args += ["--rematch-time", os.environ["REMATCH"]]
    else:
        args += ["--student-layout", "cmu"]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    rows = [r for r in csv.DictReader(l for l in open(out) if not l.startswith("#")) if r["state"] == "scoring"]
    return np.mean([float(r["score"]) for r in rows]), {int(r["frame"]): int(r["matched_teacher_frame"]) for r in rows}


def landmarks(bvh):
    out = bvh[:-4] + ".npy"
    np.save(out, mediapipe(bvh)[0])
    return out


def main():
    os.makedirs(WORK, exist_ok=True)
    print("| clip | joint | angle | BVH total | landmarks total | BVH match off > 3 | landmarks off > 3 |")
    print("|---|---|---|---|---|---|---|")
    caught = {"bvh": 0, "mp": 0}
    n = 0
    for c in CLIPS:
        t = excerpt(DATA, WORK, c)
        _, base = score(t, landmarks(t))  # the landmark student's own match, no joint turned
        for j, ax in TURNS:
            for deg in (45, -45):
                s = turned(DATA, WORK, c, j, deg, ax)
                tb, mb = score(t, s)
                tm, mm = score(t, landmarks(s))
                ob = np.mean([abs(m - f) > 3 for f, m in mb.items()])
                om = np.mean([abs(m - base.get(f, f)) > 3 for f, m in mm.items()])
                caught["bvh"] += tb <= 50
                caught["mp"] += tm <= 50
                n += 1
                print("| %s | %s | %+d | %.1f | %.1f | %.2f | %.2f |" % (c, j, deg, tb, tm, ob, om))
    print("\n45-degree turns scoring <= 50: BVH %d of %d, landmarks %d of %d" % (caught["bvh"], n, caught["mp"], n))


if __name__ == "__main__":
    main()
