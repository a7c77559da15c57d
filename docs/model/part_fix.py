#!/usr/bin/python3
"""The part to fix against plain geometry: fits the per-part score maps of a .kata
model so that the part named is the part whose joints are farthest from the teacher's, and measures
how often it agrees with geometry on real pairs of different subjects.

    /usr/bin/python3 docs/model/part_fix.py measure [build/bin/kata] [../shared/data/cmu] [models/default.kata] [OUT_DIR]
    /usr/bin/python3 docs/model/part_fix.py fit     [build/bin/kata] [../shared/data/cmu] MODEL.kata

`fit` rewrites the part maps of the model it is given; regenerate.sh runs it on models/default.kata
after calibrate.py (whose part maps it replaces), then `measure`. The part distance it scales is
the scorer's: d_p = |W^T (jc_p o e)|, the difference of part p's own joint positions (block Jc)
seen through W (sdk/src/metric/metric.hpp kJointRows; docs/model/scores.md says why).

Pairs: two clips of the same motion by different CMU subjects, teacher then student, clip-aligned
by the offline reference (`kata score --align dtw`, frame 0, the T-pose, skipped; only "scoring"
frames). Training pairs: every ordered pair of walks of different subjects among the model's
training subjects 2, 5, 7 (76 pairs). Held-out pairs: the runs of subject 9 (09_01..09_11, held out
of W's training and of every fit here) against subject 2's run 02_03, both ways (22 pairs).

Geometry of a pair: per part, the mean over the matched frames of the mean over the part's GPD
joints of the distance between student and teacher joint in the local frame (block Jc: joints
1..15 relative to the hip, yaw removed, body heights; the hip itself by its height), the issue's
"local-frame MJD". Its two largest parts are "geometry's top 2".

The model's part to fix over a pair: the part the scorer names (part_to_fix, after its
averaging, ranking and hold) on the most scoring frames; the lowest mean part score when none is
named. Also printed: the part that is the lowest on the most frames (the per-frame lowest part
score, before averaging and hold). docs/model/part_fix_rules.py replays other rules on the same CSVs.

fit: each part's distance d_p = |W^T (jc_p o e)| (scores.md) is put in body heights of joint
displacement by one factor a_p, fitted by least squares through the origin of the per-frame
geometric MJD of part p on d_p over the training pairs' frames. One map (g50, slope) then serves
every part on a_p d_p, fitted like the total (pairmean over calibrate.py's labelled pairs among the
training subjects). Stored as part d50_p = g50 / a_p and a common slope, so the lowest part score
is the part with the largest estimated joint displacement. The total map is kept as stored.
"""
import csv, os, re, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
MODE = sys.argv[1] if len(sys.argv) > 1 else "measure"
KATA = sys.argv[2] if len(sys.argv) > 2 else "build/bin/kata"
DATA = sys.argv[3] if len(sys.argv) > 3 else "../shared/data/cmu"
MODEL = sys.argv[4] if len(sys.argv) > 4 else "models/default.kata"
OUT = sys.argv[5] if len(sys.argv) > 5 else os.path.join(HERE, "eval-part-fix")
WORK = os.path.join("build", "part-fix-work")  # features and per-pair CSVs (under build/: not kept)
PARTS = ["torso_head", "left_arm", "right_arm", "left_leg", "right_leg"]
SHORT = ["torso", "L arm", "R arm", "L leg", "R leg"]
PART_JOINTS = [[0, 1, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12], [13, 14, 15]]

WALKS = ["02_01", "02_02", "05_01"] + ["07_%02d" % i for i in range(1, 13)]
RUNS_9 = ["09_%02d" % i for i in range(1, 12)]


def subject(c): return int(c.split("_")[0])


TRAIN_PAIRS = [(t, s) for t in WALKS for s in WALKS if subject(t) != subject(s)]
HELD_OUT_PAIRS = [("02_03", r) for r in RUNS_9] + [(r, "02_03") for r in RUNS_9]


def run(*args):
    subprocess.run([KATA, *args], check=True, stdout=subprocess.DEVNULL)


def features(c):
    path = os.path.join(WORK, c + ".npy")
    if not os.path.exists(path):
        run("features", "--bvh", os.path.join(DATA, c + ".bvh"), "--preset", "cmu", "--first-frame", "1", "--out", path)
    return np.load(path).astype(np.float64)


def local_joints(x):
    """Block Jc: joints 1..15 in the local frame (body heights); the hip (joint 0) by its height."""
    j = np.zeros((len(x), 16, 3))
    j[:, 1:, :] = x[:, :45].reshape(-1, 15, 3)
    j[:, 0, 1] = x[:, 45]
    return j


def geometry(t, s, a, b):
    """Frames x 5: per part, the mean joint distance of student frame a[i] to teacher frame b[i]."""
    dist = np.linalg.norm(local_joints(features(s))[a] - local_joints(features(t))[b], axis=2)
    return np.stack([dist[:, PART_JOINTS[p]].mean(1) for p in range(5)], 1)


def model_key():
    """The per-pair CSVs depend on the model's W and maps and on the scorer that wrote them: cached
    under the model file's and the kata binary's size and mtime (a rebuilt scorer with the same
    model must not reuse the old CSVs), and the shared library's beside it (../lib/libkata.so: the
    scorer lives there, and a rebuilt library does not relink the binary)."""
    st, sk = os.stat(MODEL), os.stat(KATA)
    key = "%d_%d_%d_%d" % (st.st_size, int(st.st_mtime), sk.st_size, int(sk.st_mtime))
    lib = os.path.join(os.path.dirname(os.path.abspath(KATA)), "..", "lib", "libkata.so")
    if os.path.exists(lib):
        sl = os.stat(lib)  # follows the symlink to the built file
        key += "_%d_%d" % (sl.st_size, int(sl.st_mtime))
    return key


def score_pair(t, s):
    path = os.path.join(WORK, "%s_vs_%s_%s.csv" % (t, s, model_key()))
    if not os.path.exists(path):
        run("score", "--model", MODEL, "--teacher", os.path.join(DATA, t + ".bvh"), "--student",
            os.path.join(DATA, s + ".bvh"), "--preset", "cmu", "--first-frame", "1", "--align", "dtw", "--out", path)
    rows = [r for r in csv.DictReader(open(path)) if r["state"] == "scoring"]
    a = np.array([int(r["frame"]) - 1 for r in rows])  # features row = BVH frame - 1
    b = np.array([int(r["matched_teacher_frame"]) - 1 for r in rows])
    dp = np.array([[float(r[p + "_distance"]) for p in PARTS] for r in rows])
    ps = np.array([[float(r[p + "_score"]) for p in PARTS] for r in rows])
    shown = np.array([PARTS.index(r["part_to_fix"]) if r.get("part_to_fix") in PARTS else -1 for r in rows])
    return dict(teacher=t, student=s, dp=dp, ps=ps, shown=shown, geo=geometry(t, s, a, b))


def judge(p):
    """The model's part over the pair, geometry's ranking, and the two checks of the issue."""
    g = p["geo"].mean(0)
    rank = list(np.argsort(-g))
    # The product's part to fix over the pair: the part named on the most scoring frames
    # (the scorer's part_to_fix, after its averaging and hysteresis); the lowest mean part score
    # when no part is ever named.
    named_frames = np.bincount(p["shown"][p["shown"] >= 0], minlength=5)
    named = int(named_frames.argmax()) if named_frames.sum() else int(np.argmin(p["ps"].mean(0)))
    per_frame = int(np.bincount(np.argmin(p["ps"], 1), minlength=5).argmax())
    return dict(g=g, rank=rank, named=named, per_frame=per_frame, top2=named in rank[:2],
                below_median=bool(g[named] < np.median(g)), frame_top2=per_frame in rank[:2],
                frame_below=bool(g[per_frame] < np.median(g)))


def report(title, pairs):
    js = [judge(p) for p in pairs]
    lines = ["## %s (%d pairs)\n" % (title, len(pairs)),
             "| teacher | student | geometry MJD x1000 (torso, L arm, R arm, L leg, R leg) | geometry top 2 | "
             "mean part scores | part to fix (named on the most frames) | in top 2 | per-frame lowest, most often |",
             "|---|---|---|---|---|---|---|---|"]
    for p, j in zip(pairs, js):
        mark = "yes" if j["top2"] else ("**no, below median**" if j["below_median"] else "**no** (3rd)")
        lines.append("| CMU %s | CMU %s | %s | %s, %s | %s | %s | %s | %s%s |" % (
            p["teacher"], p["student"], ", ".join("%.1f" % (1000 * v) for v in j["g"]), SHORT[j["rank"][0]],
            SHORT[j["rank"][1]], ", ".join("%.0f" % v for v in p["ps"].mean(0)), SHORT[j["named"]], mark,
            SHORT[j["per_frame"]], "" if j["frame_top2"] else " (not top 2)"))
    conf = np.zeros((5, 5), int)  # rows: geometry's largest part, columns: the part named
    for j in js: conf[j["rank"][0], j["named"]] += 1
    lines += ["", "Confusion (rows: geometry's largest part; columns: the part named):", "",
              "| geometry \\ named | " + " | ".join(SHORT) + " |", "|---|" + "---|" * 5]
    for q in range(5): lines.append("| %s | %s |" % (SHORT[q], " | ".join(str(v) for v in conf[q])))
    n = len(js)
    top2 = sum(j["top2"] for j in js); below = sum(j["below_median"] for j in js)
    ftop2 = sum(j["frame_top2"] for j in js); fbelow = sum(j["frame_below"] for j in js)
    lines += ["", "**Part to fix in geometry's top 2: %d of %d (%.1f %%); below the median MJD: %d.** "
              "Per-frame lowest, most often: %d of %d (%.1f %%); below the median: %d.\n" % (
                  top2, n, 100.0 * top2 / n, below, ftop2, n, 100.0 * ftop2 / n, fbelow)]
    return lines, dict(top2=top2, below=below, n=n, frame_top2=ftop2, frame_below=fbelow)


def model_info():
    return subprocess.run([KATA, "model-info", MODEL], check=True, capture_output=True, text=True).stdout


def fitted():
    m = re.search(r"fitted:\s+(.*)", model_info())
    return m.group(1) if m else "(no fit recorded)"


def fit():
    sys.argv = [sys.argv[0], KATA, DATA, MODEL, WORK]
    sys.path.insert(0, HERE)
    import calibrate  # the labelled clip pairs and the pairmean fit of the total map
    calibrate.WORK = os.path.join(WORK, "calibrate")
    os.makedirs(calibrate.WORK, exist_ok=True)
    train = [score_pair(t, s) for t, s in TRAIN_PAIRS]
    d = np.concatenate([p["dp"] for p in train])
    g = np.concatenate([p["geo"] for p in train])
    a = (d * g).sum(0) / (d * d).sum(0)
    labelled = [calibrate.score_pair(t, s) for t, s in calibrate.PAIRS]
    labelled = [p for p in labelled if p["subjects"] <= calibrate.TRAIN_SUBJECTS]
    pooled = [dict(label=p["label"], d=a[q] * p["dp"][:, q]) for p in labelled for q in range(5)]
    g50, slope = calibrate.fit("pairmean", pooled, "d", None)
    info = model_info()
    total = re.search(r"score map:\s+100 / \(1 \+ \(d / ([0-9.eE+-]+)\)\^([0-9.eE+-]+)\); good at >= ([0-9.]+)", info)
    method = re.search(r"fitted:\s+(.*)", info).group(1).split("; parts:")[0]
    run("calibrate", "--model", MODEL, "--out", MODEL, "--d50", total.group(1), "--slope", total.group(2),
        "--good", total.group(3), "--part-d50", ",".join("%.9g" % (g50 / a[q]) for q in range(5)),
        "--part-slope", ",".join("%.9g" % slope for _ in range(5)),
        "--method", "%s; parts: one map on a_p d_p (a_p = %s body heights per unit of d_p, least squares on the "
        "local-frame joint distance of 76 walk pairs of subjects 2, 5, 7), g50 %.5g, slope %.4g "
        "(docs/model/part_fix.py)" % (method, "/".join("%.3f" % v for v in a), g50, slope))
    print("a_p (body heights of joint displacement per unit of d_p):", " ".join("%s %.4f" % (PARTS[q], a[q]) for q in range(5)))
    print("one part map on a_p d_p: g50 %.5f body heights, slope %.3f -> part d50 %s" % (
        g50, slope, " ".join("%.5f" % (g50 / a[q]) for q in range(5))))


def measure():
    held = [score_pair(t, s) for t, s in HELD_OUT_PAIRS]
    train = [score_pair(t, s) for t, s in TRAIN_PAIRS]
    lines = ["# The part to fix against geometry: %s\n" % os.path.basename(MODEL),
             "Regenerated by `docs/model/part_fix.py measure` (CMU developer set, clip pairs named below, aligned by "
             "`kata score --align dtw`, frame 0 skipped, scoring frames only). Model maps: `%s`.\n" %
             fitted()]
    l1, s1 = report("Held out: subject 9's runs against subject 2's run, both ways", held)
    l2, s2 = report("Training subjects: walks of different subjects among 2, 5, 7 (the pairs a_p is fitted on)", train)
    lines += l1 + l2
    # Leave one subject out: the part to fix has nothing fitted on these pairs (joint angles and
    # offsets, scorer.cpp), so each subject's held-out figure is the pairs it takes part in.
    js = [(p, judge(p)) for p in held + train]
    lines += ["## Per held-out subject (pairs it takes part in)\n", "| subject | pairs | in top 2 | below median |",
              "|---|---|---|---|"]
    for sub in (1, 2, 5, 7, 9):
        mine = [j for p, j in js if sub in (subject(p["teacher"]), subject(p["student"]))]
        if not mine:
            lines.append("| %d | 0 (no clip of the same motion by another subject in the set) | - | - |" % sub)
            continue
        lines.append("| %d | %d | %d (%.1f %%) | %d |" % (sub, len(mine), sum(j["top2"] for j in mine),
                     100.0 * sum(j["top2"] for j in mine) / len(mine), sum(j["below_median"] for j in mine)))
    tot = sum(j["top2"] for _, j in js)
    lines.append("\n**All %d pairs: %d in top 2 (%.1f %%).**\n" % (len(js), tot, 100.0 * tot / len(js)))
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "part_fix.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    print("held out: %d/%d in top 2, %d below median; training walks: %d/%d, %d below median" % (
        s1["top2"], s1["n"], s1["below"], s2["top2"], s2["n"], s2["below"]))


if __name__ == "__main__":
    os.makedirs(WORK, exist_ok=True)
    {"fit": fit, "measure": measure}[MODE]()
