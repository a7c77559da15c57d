#!/usr/bin/python3
"""Does a W trained with turned joints tell style from error where the joint angles cannot?
(docs/model/scores.md, "A W trained with turned joints (tried)").

Leave one subject out over all five CMU subjects (1, 2, 5, 7, 9). For each held-out subject s two
models are trained on the other four with the coaching recipe of regenerate.sh (`kata train
--unlabeled 5000 --seed 1 --rank 50 --alpha 10000 --pca 400 --gamma 0.05 --normalisation minmax`):

  base-s: the shipped recipe's pairs only (`kata pairs --protocol cross-body --per-class 3000
          --seed 1` on the four subjects), i.e. today's W, left-one-out;
  turn-s: the same cross-body pairs, plus N_TURN turned copies (a 600-frame excerpt of a training
          subject's clip with one of the balance table's ten joints turned by +-30 or +-45 degrees,
          ../shared/tools/bend-joint) paired frame for frame with the excerpt as dissimilar, plus
          N_SIM real same-motion frame pairs of two different clips (walk, run, dance; DTW-aligned
          by `kata score --align dtw` with the shipped model) as similar.

Both, and the shipped models/default.kata (trained on 2, 5, 7: not held out for those), are then
measured on the held-out subject only:

  (a) same motion by another subject: calibrate.py's same-motion pairs that involve s, plus two
      jump pairs for subject 1 (its only motion shared with another subject), every scoring frame
      of `kata score --align dtw` (the model's own alignment, as the product scores);
  (b) turned copies of s's excerpts at 30 and at 45 degrees (ten joints, both signs), against the
      excerpt, the same way.

Figures, per fold and pooled over the five folds: AUC (probability that a turned frame's value is
above a same-motion frame's) and the share of turned frames above the 90th percentile of the
same-motion frames, for the W distance of each model and for the worst part's joint angle (the
shipped coaching part angle, recovered from the CSV's part scores as coaching_frontier.py does).

    /usr/bin/python3 docs/model/w_turned.py [build/bin/kata] [../shared/data/cmu] [models/default.kata] [OUT_DIR]

Work files go to build/w-turned (not kept); the report to OUT_DIR/w_turned_TAG.md. Variants by environment:
TAG (names the variant's files), N_TURN, N_SIM (pairs per fold), NEG_WEIGHT (kata train
--negative-weight for the turned-joint W; off by default: the RDSR then uses negatives only for
delta*), RANK (its rank, default 50).
"""
import csv, glob, os, random, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
KATA = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/bin/kata")
DATA = os.path.abspath(sys.argv[2] if len(sys.argv) > 2 else "../shared/data/cmu")
MODEL = os.path.abspath(sys.argv[3] if len(sys.argv) > 3 else "models/default.kata")
OUT = sys.argv[4] if len(sys.argv) > 4 else os.path.join(HERE, "eval-w-turned")
BEND = os.path.join(os.path.dirname(os.path.dirname(DATA)), "tools", "bend-joint")
WORK = os.path.abspath(os.path.join("build", "w-turned"))
sys.path.insert(0, HERE)
sys.argv = sys.argv[:1]
from calibrate import PAIRS, MOTION  # noqa: E402

SUBJECTS = [1, 2, 5, 7, 9]
TURNS = [("LeftForeArm", "Y"), ("RightForeArm", "Y"), ("LeftArm", "Z"), ("RightArm", "Z"), ("LeftLeg", "X"),
         ("RightLeg", "X"), ("LeftUpLeg", "X"), ("RightUpLeg", "X"), ("Spine1", "X"), ("Neck1", "X")]
ANGLES = [-45, -30, 30, 45]
TURN_CLIPS = {1: ["01_01", "01_08"], 2: ["02_01", "02_03", "02_05"], 5: ["05_01", "05_18", "05_02"],
              7: ["07_01", "07_04"], 9: ["09_01", "09_02", "09_12"]}
EXCERPT = 600
N_TURN = int(os.environ.get("N_TURN", 3000))
N_SIM = int(os.environ.get("N_SIM", 3000))
TAG = os.environ.get("TAG", "turn")
RANK = os.environ.get("RANK", "50")  # the turned-joint W's rank (the shipped recipe: 50)
NEG_WEIGHT = os.environ.get("NEG_WEIGHT", "")  # kata train --negative-weight for the turned-joint W ("": off)
TEST_SAME = [(t, s) for t, s in PAIRS if MOTION[t] == MOTION[s]] + [("01_01", "02_04"), ("01_13", "02_04")]
PARTS = ["torso_head", "left_arm", "right_arm", "left_leg", "right_leg"]
UNSCORED = []
TRAIN_OPTS = ["--unlabeled", "5000", "--seed", "1", "--rank", "50", "--alpha", "10000", "--pca", "400",
              "--gamma", "0.05", "--normalisation", "minmax"]


def subj(c):
    return int(c[1:3]) if c.startswith("x") else int(c[:2])


def run(args, log=None, check=True):
    subprocess.run(["nice"] + args, check=check, stdout=open(log, "w") if log else subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL if not check else None)


def frames_of(path):
    for line in open(path):
        if line.startswith("Frames:"):
            return int(line.split()[1])


def data_dir():
    d = os.path.join(WORK, "data")
    os.makedirs(d, exist_ok=True)
    for f in glob.glob(os.path.join(DATA, "*.bvh")):
        if not os.path.exists(os.path.join(d, os.path.basename(f))):
            os.symlink(f, os.path.join(d, os.path.basename(f)))
    for cs in TURN_CLIPS.values():
        for c in cs:
            x = os.path.join(d, "x%s.bvh" % c)
            if not os.path.exists(x):
                lines = open(os.path.join(DATA, c + ".bvh")).read().splitlines()
                i = next(k for k, l in enumerate(lines) if l.strip().startswith("MOTION"))
                body = [l for l in lines[i + 3:] if l.strip()][:EXCERPT + 1]
                lines[i + 1] = "Frames: %d" % len(body)
                open(x, "w").write("\n".join(lines[:i + 3] + body) + "\n")
            for j, ax in TURNS:
                for g in ANGLES:
                    t = os.path.join(d, turned_name(c, j, g))
                    if not os.path.exists(t):
                        subprocess.run([BEND, x, t, j, str(g), ax], check=True)
    return d


def turned_name(c, j, g):
    return "x%s-%s-%s%d.bvh" % (c, j, "p" if g > 0 else "m", abs(g))


def score(model, teacher, student, out):
    if not os.path.exists(out):
        run([KATA, "score", "--model", model, "--teacher", teacher, "--student", student, "--preset", "cmu",
             "--first-frame", "1", "--align", "dtw", "--out", out], check=False)
    # `kata score` refuses (non-zero exit, the CSV still written) a student the DTW put wholly past
    # the teacher's end: no scoring frame; such a pair is left out and counted (UNSCORED).
    if not os.path.exists(out):
        raise SystemExit("kata score wrote nothing: " + out)
    rows = [r for r in csv.DictReader(l for l in open(out) if not l.startswith("#")) if r["state"] == "scoring"]
    d = np.array([float(r["distance"]) for r in rows])
    ps = np.clip(np.array([[float(r[p + "_score"]) for p in PARTS] for r in rows] or [[100.0] * 5]), 1e-6, 100.0)
    angle = (40.0 * np.maximum(100.0 / ps - 1.0, 0.0) ** (1 / 5.0)).max(1)
    frames = [(int(r["matched_teacher_frame"]), int(r["frame"])) for r in rows]
    if not rows:
        UNSCORED.append(out)
        angle = np.zeros(0)
    return d, angle, frames


def similar_pairs(data):
    """Every unordered pair of two different walk, run or dance clips (09_12, a mixed navigation
    take, left out), the longer as teacher, DTW-aligned with the shipped model: (teacher, student,
    [(teacher frame, student frame)])."""
    clips = sorted(c for c in MOTION)
    out = []
    os.makedirs(os.path.join(WORK, "align"), exist_ok=True)
    for i, a in enumerate(clips):
        for b in clips[i + 1:]:
            if MOTION[a] != MOTION[b]:
                continue
            fa, fb = frames_of(os.path.join(data, a + ".bvh")), frames_of(os.path.join(data, b + ".bvh"))
            t, s = (a, b) if fa >= fb else (b, a)
            _, _, fr = score(MODEL, os.path.join(data, t + ".bvh"), os.path.join(data, s + ".bvh"),
                             os.path.join(WORK, "align", "%s_%s.csv" % (t, s)))
            out.append((t, s, [(tf, sf) for tf, sf in fr if tf >= 4 and sf >= 4]))
    return out


def fold_pairs(data, s, sims):
    others = [k for k in SUBJECTS if k != s]
    pdir = os.path.join(WORK, "pairs")
    os.makedirs(pdir, exist_ok=True)
    cb = os.path.join(pdir, "cross-body-%d.csv" % s)
    if not os.path.exists(cb):
        run([KATA, "pairs", "--data", data, "--subjects"] + [str(k) for k in others] +
            ["--protocol", "cross-body", "--per-class", "3000", "--seed", "1", "--out", cb])
    extra = os.path.join(pdir, "%s-%d.csv" % (TAG, s))
    if not os.path.exists(extra):
        rng = random.Random(s)
        rows = []
        clips = [c for k in others for c in TURN_CLIPS[k]]
        for _ in range(N_TURN):
            c, (j, ax), g = rng.choice(clips), rng.choice(TURNS), rng.choice(ANGLES)
            f = rng.randint(4, min(EXCERPT, frames_of(os.path.join(data, c + ".bvh")) - 1))
            rows.append(("x%s.bvh" % c, f, turned_name(c, j, g), f, 0))
        pool = [p for p in sims if subj(p[0]) != s and subj(p[1]) != s and p[2]]
        for _ in range(N_SIM if pool else 0):
            t, st, fr = rng.choice(pool)
            tf, sf = rng.choice(fr)
            rows.append((t + ".bvh", tf, st + ".bvh", sf, 1))
        with open(extra, "w") as f:
            f.write("# w_turned.py: %d turned-joint pairs (label 0), %d real same-motion pairs (label 1), subjects %s\n"
                    % (N_TURN, N_SIM if pool else 0, ",".join(map(str, others))))
            f.write("clip_a,frame_a,clip_b,frame_b,label\n")
            for r in rows:
                f.write("%s,%d,%s,%d,%d\n" % r)
    return cb, extra


def train(data, s, pairs, name, extra_opts=()):
    out = os.path.join(WORK, "models", "%s-%d.kata" % (name, s))
    os.makedirs(os.path.dirname(out), exist_ok=True)
    if not os.path.exists(out):
        args = [KATA, "train", "--data", data, "--subjects"] + [str(k) for k in SUBJECTS if k != s]
        for p in pairs:
            args += ["--pairs", p]
        opts = list(TRAIN_OPTS)
        if "--rank" in extra_opts:  # one --rank only (the CLI refuses two)
            i = list(extra_opts).index("--rank")
            opts[opts.index("--rank") + 1] = extra_opts[i + 1]
            extra_opts = list(extra_opts[:i]) + list(extra_opts[i + 2:])
        run(args + opts + list(extra_opts) + ["--threads", "1", "--out", out], out + ".log")
    return out


def measure(data, s, model, name):
    """(same-motion values, {30: turned values, 45: ...}) of the W distance and the worst part angle."""
    sdir = os.path.join(WORK, "scores", name)
    os.makedirs(sdir, exist_ok=True)
    same_d, same_a = [], []
    for t, st in TEST_SAME:
        if s in (subj(t), subj(st)):
            d, a, _ = score(model, os.path.join(data, t + ".bvh"), os.path.join(data, st + ".bvh"),
                            os.path.join(sdir, "%s_vs_%s.csv" % (t, st)))
            same_d.append(d)
            same_a.append(a)
    tur_d, tur_a = {30: [], 45: []}, {30: [], 45: []}
    for c in TURN_CLIPS[s]:
        for j, _ in TURNS:
            for g in ANGLES:
                n = turned_name(c, j, g)
                d, a, _ = score(model, os.path.join(data, "x%s.bvh" % c), os.path.join(data, n),
                                os.path.join(sdir, n + ".csv"))
                tur_d[abs(g)].append(d)
                tur_a[abs(g)].append(a)
    return (same_d, tur_d), (same_a, tur_a)


def frontier(same, tur, slope):
    """The map 100 / (1 + (v / v50)^slope) with v50 set so that the mean over the same-motion pairs
    of each pair's mean total is 70 (item 5's floor); then the turned copies' mean totals."""
    def m(v, v50):
        return 100.0 / (1.0 + (v / v50) ** slope)
    lo, hi = 1e-6, 1e6
    for _ in range(200):
        mid = np.sqrt(lo * hi)
        if np.mean([m(v, mid).mean() for v in same if len(v)]) < 70.0:
            lo = mid
        else:
            hi = mid
    return {g: np.array([m(v, hi).mean() for v in tur[g] if len(v)]) for g in (30, 45)}


COMBO_GRID = [(a50, ka, kd) for a50 in (35, 40, 45, 50, 60, 80) for ka in (5, 10) for kd in (5, 10)]


def combo(sd, sa, td, ta, a50, ka, kd):
    """total = min(W map, worst part angle map), the shipped form, with d50 set so that the
    same-motion pairs' mean total is 70; None when the angle map alone is under 70."""
    def t(d, a, d50):
        return np.minimum(100.0 / (1.0 + (d / d50) ** kd), 100.0 / (1.0 + (a / a50) ** ka))
    if np.mean([t(d, a, 1e9).mean() for d, a in zip(sd, sa) if len(d)]) < 70.0:
        return None
    lo, hi = 1e-6, 1e9
    for _ in range(200):
        mid = np.sqrt(lo * hi)
        if np.mean([t(d, a, mid).mean() for d, a in zip(sd, sa) if len(d)]) < 70.0:
            lo = mid
        else:
            hi = mid
    return {g: np.array([t(d, a, hi).mean() for d, a in zip(td[g], ta[g]) if len(d)]) for g in (30, 45)}


def auc(neg, pos):
    """P(pos > neg) + P(pos == neg) / 2, by ranks."""
    x = np.concatenate([neg, pos])
    order = x.argsort(kind="mergesort")
    ranks = np.empty(len(x))
    xs = x[order]
    i = 0
    while i < len(xs):
        j = i
        while j + 1 < len(xs) and xs[j + 1] == xs[i]:
            j += 1
        ranks[order[i:j + 1]] = (i + j) / 2.0 + 1
        i = j + 1
    rp = ranks[len(neg):].sum()
    return (rp - len(pos) * (len(pos) + 1) / 2.0) / (len(pos) * len(neg))


def figures(same, tur):
    p90 = np.percentile(same, 90)
    return {g: (auc(same, tur[g]), (tur[g] > p90).mean()) for g in (30, 45)}


def main():
    os.makedirs(OUT, exist_ok=True)
    data = data_dir()
    sims = similar_pairs(data)
    rows, pooled, front, combos = [], {}, {}, {}
    sizes = []
    for s in SUBJECTS:
        cb, extra = fold_pairs(data, s, sims)
        n_extra = sum(1 for l in open(extra) if l[:1] not in "#c")
        sizes.append((s, sum(1 for l in open(cb) if l[:1] not in "#c"), n_extra))
        models = [("shipped W", MODEL, "shipped"), ("today's recipe, LOSO W", train(data, s, [cb], "base"), "base-%d" % s),
                  ("turned-joint W (%s), LOSO" % TAG, train(data, s, [cb, extra], TAG, (["--negative-weight", NEG_WEIGHT] if NEG_WEIGHT else []) + ["--rank", RANK]), "%s-%d" % (TAG, s))]
        for k, (label, path, name) in enumerate(models):
            (sdl, tdl), (sal, tal) = measure(data, s, path, name)
            for a50, ka, kd in COMBO_GRID:
                fr = combo(sdl, sal, tdl, tal, a50, ka, kd)
                q = combos.setdefault((label, a50, ka, kd), {30: [], 45: [], "ok": True})
                if fr is None:
                    q["ok"] = False
                else:
                    for g in (30, 45):
                        q[g].append(fr[g])
            cands = [(label + ": distance", sdl, tdl)] + ([("worst part angle (shipped)", sal, tal)] if k == 0 else [])
            for lab, same_l, tur_l in cands:
                for slope in (2, 5, 10):
                    fr = frontier(same_l, tur_l, slope)
                    q = front.setdefault((lab, slope), {30: [], 45: []})
                    for g in (30, 45):
                        q[g].append(fr[g])
                same = np.concatenate(same_l)
                tur = {g: np.concatenate(v) for g, v in tur_l.items()}
                f = figures(same, tur)
                rows.append((s, lab, len(same), len(tur[30]), f))
                p = pooled.setdefault(lab, ([], {30: [], 45: []}))
                # Pooled: each fold's values are put on its own same-motion scale (rank among the
                # fold's same-motion frames), so models of different folds can be pooled.
                ref = np.sort(same)
                p[0].append(np.searchsorted(ref, same, side="right") / len(ref))
                for g in (30, 45):
                    p[1][g].append(np.searchsorted(ref, tur[g], side="right") / len(ref))
            print("fold %d: %s done" % (s, label), flush=True)
    with open(os.path.join(OUT, "w_turned_%s.md" % TAG), "w") as f:
        f.write("# A W trained with turned joints: style against error, leave one subject out\n\n")
        f.write("`/usr/bin/python3 docs/model/w_turned.py build/bin/kata ../shared/data/cmu models/default.kata "
                "docs/model/eval-w-turned` (TAG=%s, N_TURN=%d, N_SIM=%d, NEG_WEIGHT=%s, RANK=%s; see the script's docstring).\n\n"
                % (TAG, N_TURN, N_SIM, NEG_WEIGHT or "off", RANK))
        f.write("Training pairs per fold (held-out subject: cross-body rows, turned + same-motion rows): %s.\n\n"
                % "; ".join("%d: %d, %d" % z for z in sizes))
        f.write("AUC: probability that a turned frame's value exceeds a same-motion frame's (1 = separated, "
                "0.5 = blind). >P90: share of turned frames above the 90th percentile of the same-motion frames.\n\n")
        f.write("| held out | measure | same-motion frames | turned frames per angle | AUC 30 | >P90 30 | AUC 45 | >P90 45 |\n")
        f.write("|---|---|---|---|---|---|---|---|\n")
        for s, lab, ns, nt, fg in rows:
            f.write("| %d | %s | %d | %d | %.3f | %.2f | %.3f | %.2f |\n" % (s, lab, ns, nt, fg[30][0], fg[30][1],
                                                                         fg[45][0], fg[45][1]))
        f.write("\nPooled over the five folds (each fold's values ranked among its own same-motion frames):\n\n")
        f.write("| measure | AUC 30 | >P90 30 | AUC 45 | >P90 45 |\n|---|---|---|---|---|\n")
        for lab, (same, tur) in pooled.items():
            fg = figures(np.concatenate(same), {g: np.concatenate(v) for g, v in tur.items()})
            f.write("| %s | %.3f | %.2f | %.3f | %.2f |\n" % (lab, fg[30][0], fg[30][1], fg[45][0], fg[45][1]))
        f.write("\nEach measure alone as the total, 100 / (1 + (v / v50)^slope), v50 set per fold so that the "
                "same-motion pairs' mean total is 70 (item 5's floor, pooled over the fold's pairings): the turned "
                "copies' mean totals (per copy, over its scoring frames), pooled over the folds. '45 over 50': copies "
                "at +-45 degrees whose mean total is over 50 (items 1 and 4 ask <= 50).\n\n")
        f.write("| measure | slope | 45 over 50 (of copies) | mean total at 45 | mean total at 30 |\n|---|---|---|---|---|\n")
        for (lab, slope), q in front.items():
            t45, t30 = np.concatenate(q[45]), np.concatenate(q[30])
            f.write("| %s | %d | %d of %d | %.1f | %.1f |\n" % (lab, slope, (t45 > 50).sum(), len(t45), t45.mean(), t30.mean()))
        f.write("\nThe shipped form, total = min(100 / (1 + (d / d50)^kd), 100 / (1 + (angle / a50)^ka)) with each "
                "model's W as the gate (d and the worst part angle from the same `kata score` run), d50 set per fold so "
                "that the same-motion mean total is 70; per model, the three grid points (a50 35-80, ka 5/10, kd 5/10) "
                "with the fewest copies at +-45 over 50 (points where the angle map alone is under 70 on a fold are "
                "left out):\n\n")
        f.write("| gate W | a50, ka, kd | 45 over 50 (of copies) | mean total at 45 | mean total at 30 |\n|---|---|---|---|---|\n")
        for label in dict.fromkeys(k[0] for k in combos):
            pts = []
            for (lab, a50, ka, kd), q in combos.items():
                if lab == label and q["ok"]:
                    t45, t30 = np.concatenate(q[45]), np.concatenate(q[30])
                    pts.append(((t45 > 50).sum(), len(t45), t45.mean(), t30.mean(), a50, ka, kd))
            for n, tot, m45, m30, a50, ka, kd in sorted(pts)[:3]:
                f.write("| %s | %g, %g, %g | %d of %d | %.1f | %.1f |\n" % (label, a50, ka, kd, n, tot, m45, m30))
        f.write("\nLeft out (`kata score --align dtw` put the whole student past the teacher's end: no scoring "
                "frame): %d: %s\n" % (len(set(UNSCORED)), ", ".join(sorted(set(os.path.relpath(u, WORK) for u in UNSCORED))) or "none"))
    print(open(os.path.join(OUT, "w_turned_%s.md" % TAG)).read())


if __name__ == "__main__":
    main()
