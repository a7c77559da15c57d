#!/usr/bin/python3
"""Fits the score map of a .kata model on real cross-subject clip pairs and writes the report.

    /usr/bin/python3 docs/model/calibrate.py [build/bin/kata] [../shared/data/cmu] [models/default.kata] [OUT_DIR]

Every pair is a teacher clip followed by a student clip with `kata score` (clip-aligned, frame 0,
the T-pose, skipped; the first 0.25 s "calibrating" and the frames after the teacher clip ended
are not used). Data are named by dataset (CMU developer set) and clip, never by path.

Map: score(d) = 100 / (1 + (d / d50)^slope), the same form per body part on its part distance.
Candidates (chosen by leave-one-subject-out over the subjects of the pairs, never on a test pair):
  default   d50 = delta*, slope 2 (the map before calibration)
  loglogit  maximum-likelihood logistic regression of "same motion" on log d (pairs weighted equally)
  pairmean  least squares of each pair's mean score / 100 against its label (1 same, 0 different)
Slopes are bounded to [0.5, 6] (a step function would fit pair means best but tells a student
nothing between "perfect" and "wrong"). The shipped map is the chosen method fitted on the pairs among the model's training subjects
(2, 5, 7); pairs involving subject 9 (run) are the held-out test.
"""
import csv, os, re, subprocess, sys
import numpy as np
from scipy.optimize import minimize

KATA = sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata"
DATA = sys.argv[2] if len(sys.argv) > 2 else "../shared/data/cmu"
MODEL = sys.argv[3] if len(sys.argv) > 3 else "models/default.kata"
OUT = sys.argv[4] if len(sys.argv) > 4 else "docs/model/eval-calibration"
WORK = os.path.join(OUT, "work")  # per-pair CSVs and features (not kept in the repository)
PARTS = ["torso_head", "left_arm", "right_arm", "left_leg", "right_leg"]
TRAIN_SUBJECTS = {2, 5, 7}
SLOPE_MIN, SLOPE_MAX = 0.5, 6.0
GOOD = 70.0  # documented "good" total: a faithful performance by another person (target >= 70)

MOTION = {}
for c in ["02_01", "02_02", "05_01"] + ["07_%02d" % i for i in range(1, 13)]: MOTION[c] = "walk"
for c in ["02_03"] + ["09_%02d" % i for i in range(1, 12)]: MOTION[c] = "run"
for c in ["05_18", "05_19", "05_20"]: MOTION[c] = "dance"

# teacher, student. Same motion by another subject (dance: another take of the same dance).
PAIRS = [
    ("02_01", "07_01"), ("07_01", "02_01"), ("02_01", "05_01"), ("05_01", "02_02"), ("07_02", "05_01"),
    ("02_02", "07_03"), ("07_06", "02_01"), ("05_01", "07_08"),
    ("02_03", "09_01"), ("09_02", "02_03"), ("02_03", "09_05"), ("09_07", "02_03"),
    ("05_18", "05_19"), ("05_19", "05_20"), ("05_20", "05_18"),
    # different motions
    ("02_01", "09_01"), ("09_03", "07_01"), ("07_02", "02_03"), ("02_03", "05_01"), ("05_01", "09_04"),
    ("02_01", "05_18"), ("05_19", "07_01"), ("07_03", "05_20"), ("05_18", "02_02"),
    ("05_20", "09_01"), ("09_06", "05_19"), ("02_03", "05_18"), ("05_19", "02_03"),
]


def subject(c): return int(c.split("_")[0])


def run(*args):
    subprocess.run([KATA, *args], check=True, stdout=subprocess.DEVNULL)


def features(c):
    path = os.path.join(WORK, c + ".npy")
    if not os.path.exists(path):
        run("features", "--bvh", os.path.join(DATA, c + ".bvh"), "--preset", "cmu", "--first-frame", "1", "--out", path)
    return np.load(path).astype(np.float64)


def local_joints(x):
    """Block 1 (Jc): joints 1..15 in the yaw-free local frame (body heights) and the hip height."""
    j = np.zeros((len(x), 16, 3))
    j[:, 1:, :] = x[:, :45].reshape(-1, 15, 3)
    j[:, 0, 1] = x[:, 45]
    return j


PART_JOINTS = [[0, 1, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12], [13, 14, 15]]


def score_pair(t, s):
    csv_path = os.path.join(WORK, "%s_vs_%s.csv" % (t, s))
    if not os.path.exists(csv_path):
        run("score", "--model", MODEL, "--teacher", os.path.join(DATA, t + ".bvh"), "--student",
            os.path.join(DATA, s + ".bvh"), "--preset", "cmu", "--first-frame", "1", "--out", csv_path)
    rows = [r for r in csv.DictReader(open(csv_path)) if r["state"] == "scoring"]
    d = np.array([float(r["distance"]) for r in rows])
    dp = np.array([[float(r[p + "_distance"]) for p in PARTS] for r in rows])
    share = np.array([[float(r[p]) for p in PARTS] for r in rows])
    js, jt = local_joints(features(s)), local_joints(features(t))
    a = np.array([int(r["frame"]) - 1 for r in rows]); b = np.array([int(r["matched_teacher_frame"]) - 1 for r in rows])
    dist = np.linalg.norm(js[a] - jt[b], axis=2)  # frames x 16, body heights
    geo = np.array([dist[:, PART_JOINTS[p]].mean() for p in range(5)])
    return dict(teacher=t, student=s, label=int(MOTION[t] == MOTION[s]), d=d, dp=dp, share=share, geo=geo,
                pairing="%s vs %s" % tuple(sorted((MOTION[t], MOTION[s]))),
                subjects={subject(t), subject(s)})


def smap(d, d50, slope):
    return 100.0 / (1.0 + np.power(np.maximum(d, 1e-12) / d50, slope))


def fit(method, pairs, key, delta):
    """(d50, slope) for the distances pairs[i][key] (column `col` if a tuple)."""
    def dist(p):
        return p[key[0]][:, key[1]] if isinstance(key, tuple) else p[key]
    if method == "default":
        return delta, 2.0
    x0 = [np.log(np.median(np.concatenate([dist(p) for p in pairs]))), 0.0]
    if method == "loglogit":
        def loss(th):
            d50, k = np.exp(th[0]), slope_of(th[1])
            tot = 0.0
            for p in pairs:
                q = np.clip(smap(dist(p), d50, k) / 100.0, 1e-9, 1 - 1e-9)
                tot -= np.mean(np.log(q) if p["label"] else np.log(1 - q))
            return tot / len(pairs)
    else:  # pairmean
        def loss(th):
            d50, k = np.exp(th[0]), slope_of(th[1])
            return np.mean([(np.mean(smap(dist(p), d50, k)) / 100.0 - p["label"]) ** 2 for p in pairs])
    r = minimize(loss, x0, method="Nelder-Mead", options=dict(xatol=1e-6, fatol=1e-10, maxiter=4000))
    return float(np.exp(r.x[0])), float(slope_of(r.x[1]))


def slope_of(theta):
    """Slopes are kept in [SLOPE_MIN, SLOPE_MAX]: a steeper map turns the score into a step (a pair
    mean fit would drive it there), and a student needs a graded score."""
    return SLOPE_MIN + (SLOPE_MAX - SLOPE_MIN) / (1.0 + np.exp(-theta))


def pair_loss(pairs, d50, k, key="d"):
    return float(np.mean([(np.mean(smap(p[key], d50, k)) / 100.0 - p["label"]) ** 2 for p in pairs]))


def model_info(key):
    out = subprocess.run([KATA, "model-info", MODEL], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith(key + ":"): return line[len(key) + 1:].strip()
    raise SystemExit("no %s in model-info" % key)


def model_delta():
    return float(model_info("delta*").split()[0])


def dataset_description():
    """The model's data description with a machine path replaced by the dataset's name."""
    return re.sub(r"data=[^;]*", lambda m: "dataset=" + os.path.basename(m.group(0)[5:].rstrip("/")), model_info("data"))


def main():
    os.makedirs(WORK, exist_ok=True)
    delta = model_delta()
    pairs = [score_pair(t, s) for t, s in PAIRS]
    subjects = sorted(set().union(*[p["subjects"] for p in pairs]))
    lines = []
    # 1. Method choice: leave one training subject out, on pairs among the training subjects.
    train = [p for p in pairs if p["subjects"] <= TRAIN_SUBJECTS]
    lines.append("## Method choice (leave one subject out over training subjects %s)\n" % sorted(TRAIN_SUBJECTS))
    lines.append("Validation loss = mean over the held-out subject's pairs of (mean score / 100 - label)^2.\n")
    lines.append("| method | " + " | ".join("val. subject %d" % s for s in sorted(TRAIN_SUBJECTS)) + " | mean |")
    lines.append("|---|" + "---|" * (len(TRAIN_SUBJECTS) + 1))
    best, best_loss = None, 1e9
    for method in ["default", "loglogit", "pairmean"]:
        losses = []
        for s in sorted(TRAIN_SUBJECTS):
            fit_on = [p for p in train if s not in p["subjects"]]
            val = [p for p in train if s in p["subjects"]]
            d50, k = fit(method, fit_on, "d", delta)
            losses.append(pair_loss(val, d50, k))
        m = float(np.mean(losses))
        lines.append("| %s | %s | %.4f |" % (method, " | ".join("%.4f" % l for l in losses), m))
        if m < best_loss - 1e-12: best, best_loss = method, m
    lines.append("\nChosen: **%s**.\n" % best)

    # 2. The per-pairing table: each pair scored by the map fitted without its subjects.
    def loso_maps(p):
        fit_on = [q for q in pairs if not (q["subjects"] & p["subjects"])]
        total = fit(best, fit_on, "d", delta) if fit_on else None
        parts = [fit(best, fit_on, ("dp", i), delta) for i in range(5)] if fit_on else None
        return total, parts

    rows = []
    for p in pairs:
        total, parts = loso_maps(p)
        if total is None: continue
        s = smap(p["d"], *total)
        ps = np.array([smap(p["dp"][:, i], *parts[i]) for i in range(5)]).T  # frames x 5
        mean_part = ps.mean(0)
        blamed = int(np.argmin(mean_part))
        old = int(np.argmax(p["share"].mean(0)))
        geo_rank = list(np.argsort(-p["geo"]))
        rows.append(dict(p=p, score=float(s.mean()), frames=len(s), blamed=blamed, old=old, geo_rank=geo_rank,
                         mean_part=mean_part, named=bool(s.mean() < GOOD)))
    lines.append("## Scores per pair (leave-one-subject-out: each pair scored by the map fitted on the pairs "
                 "sharing no subject with it)\n")
    lines.append("| teacher | student | pairing | frames | mean score | part scores (torso, L arm, R arm, L leg, R leg) | "
                 "blamed (part score) | blamed (old: share of d^2) | geometry top 2 | blame in top 2 |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        p = r["p"]
        ok = r["blamed"] in r["geo_rank"][:2]
        lines.append("| CMU %s | CMU %s | %s | %d | %.1f | %s | %s | %s | %s, %s | %s |" % (
            p["teacher"], p["student"], p["pairing"], r["frames"], r["score"],
            ", ".join("%.0f" % v for v in r["mean_part"]), PARTS[r["blamed"]] + ("" if r["named"] else " (not named: good)"),
            PARTS[r["old"]], PARTS[r["geo_rank"][0]], PARTS[r["geo_rank"][1]], "yes" if ok else "**no**"))
    lines.append("\n## Per pairing (leave-one-subject-out means)\n")
    lines.append("| pairing | same motion | pairs | mean score | target |")
    lines.append("|---|---|---|---|---|")
    for pairing in sorted({r["p"]["pairing"] for r in rows}):
        rs = [r for r in rows if r["p"]["pairing"] == pairing]
        same = rs[0]["p"]["label"]
        lines.append("| %s | %s | %d | %.1f | %s |" % (pairing, "yes" if same else "no", len(rs),
                     np.mean([r["score"] for r in rs]), ">= 70" if same else "<= 25"))
    blame_ok = sum(r["blamed"] in r["geo_rank"][:2] for r in rows)
    old_ok = sum(r["old"] in r["geo_rank"][:2] for r in rows)
    lines.append("\nBlame within the two geometrically most different parts: %d of %d pairs (the old share-of-d^2 "
                 "blame: %d of %d).\n" % (blame_ok, len(rows), old_ok, len(rows)))

    # 3. The shipped map: fitted on the training subjects' pairs only; held-out test = pairs with subject 9.
    total = fit(best, train, "d", delta)
    parts = [fit(best, train, ("dp", i), delta) for i in range(5)]
    test = [p for p in pairs if 9 in p["subjects"]]
    lines.append("## Shipped map (fitted on the pairs among subjects 2, 5, 7; tested on the pairs with subject 9)\n")
    lines.append("d50 = %.6g, slope = %.4g; parts (d50, slope): %s; good score %.0f.\n" % (
        total[0], total[1], "; ".join("%s %.4g, %.3g" % (PARTS[i], *parts[i]) for i in range(5)), GOOD))
    lines.append("| teacher | student | pairing | mean score (shipped map) |")
    lines.append("|---|---|---|---|")
    for p in test:
        lines.append("| CMU %s | CMU %s | %s | %.1f |" % (p["teacher"], p["student"], p["pairing"], smap(p["d"], *total).mean()))
    for label, name in [(1, "same motion"), (0, "different motion")]:
        ps = [p for p in test if p["label"] == label]
        if ps:
            lines.append("\nHeld-out %s (subject 9 pairs): mean score %.1f over %d pairs." % (
                name, np.mean([smap(p["d"], *total).mean() for p in ps]), len(ps)))
    k = total[1]
    lines.append("\nWhat the numbers mean (shipped map): score 90 at d = %.4g, 60 at %.4g, 30 at %.4g (d50 = %.4g).\n" % (
        total[0] * (1 / 9) ** (1 / k), total[0] * (40 / 60) ** (1 / k), total[0] * (70 / 30) ** (1 / k), total[0]))
    with open(os.path.join(OUT, "calibration.md"), "w") as f:
        f.write("# Score calibration of %s\n\nRegenerated by `docs/model/calibrate.py` (CMU developer set, clips named "
                "below; frame 0 skipped, clip-aligned).\n\n" % os.path.basename(MODEL))
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(OUT, "shipped.txt"), "w") as f:
        f.write("%r %r %r\n" % (total, parts, best))
    run("calibrate", "--model", MODEL, "--out", MODEL, "--d50", "%.9g" % total[0], "--slope", "%.9g" % total[1],
        "--part-d50", ",".join("%.9g" % p[0] for p in parts), "--part-slope", ",".join("%.9g" % p[1] for p in parts),
        "--good", "%g" % GOOD, "--method", "%s, fitted on CMU developer-set clip pairs of subjects 2, 5, 7 "
        "(docs/model/calibrate.py)" % best, "--data", dataset_description())
    print(open(os.path.join(OUT, "calibration.md")).read())


if __name__ == "__main__":
    main()
