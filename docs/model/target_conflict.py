#!/usr/bin/python3
"""Can one score meet the same-motion target (same motion by another subject >= 70, no pair below 50)
and the 45-degree catch (one joint turned 45 degrees on every frame -> total <= 50) at once?
(docs/model/scores.md, "Can item 5 and the 45-degree catch both hold? (measured)").

Per frame pair, the vector of the 15 per-bone angles the shipped worst part's joint angle takes its
maximum over (sdk/src/metric/pose_error.cpp part_error: bone parent -> child of GPD joints 1..15,
the head and both arms in the chest frame, the rest in GPD's local frame), from `kata features`
(block Jc), for
  (a) every DTW-aligned frame pair of calibrate.py's same-motion pairs (walk and run: another
      subject; dance: another take of subject 5; `kata score --align dtw`, shipped model, scoring
      frames), the pairs w_turned.py measures item 5 on;
  (b) every frame of a turned copy against its original, frame for frame (w_turned.py's 600-frame
      excerpts and ../shared/tools/bend-joint; the ten joints of the balance table at +-30 and +-45
      degrees) of one clip per motion: 02_01 and 07_01 (walk), 09_01 (run), 05_18 (dance).

Dominance: a same-motion pair dominates a turned pair when its angle is >= on every one of the 15
bones. Any score monotone in the per-bone angles scores a dominating pair no higher than the turned
one. Counted per frame (random subsample of both sides, per motion) and per clip (per-bone mean,
median and 90th percentile over the frames); per clip also with `kata score`'s online alignment on
both sides (as a lesson scores), and two monotone clip-level measures (the largest bone's clip
mean; the clip mean of each frame's largest bone) against a threshold.

    /usr/bin/python3 docs/model/target_conflict.py [build/bin/kata] [../shared/data/cmu] [models/default.kata] [OUT_DIR]

Work files (features, alignments, turned copies) are cached in build/dominance; the report goes to
OUT_DIR/target_conflict.md (default docs/model/eval-target-conflict).
"""
import csv, os, subprocess, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ARGS = sys.argv[1:]
KATA = os.path.abspath(ARGS[0] if len(ARGS) > 0 else "build/bin/kata")
DATA = os.path.abspath(ARGS[1] if len(ARGS) > 1 else "../shared/data/cmu")
MODEL = os.path.abspath(ARGS[2] if len(ARGS) > 2 else "models/default.kata")
OUT = ARGS[3] if len(ARGS) > 3 else os.path.join(HERE, "eval-target-conflict")
WORK = "build/dominance"
sys.path.insert(0, HERE)
sys.argv = sys.argv[:1] + [KATA, DATA, MODEL]
import w_turned  # noqa: E402  (its excerpts, turned copies, joints, angles and test pairs)
from calibrate import MOTION  # noqa: E402

w_turned.WORK = WORK
w_turned.TURN_CLIPS = {2: ["02_01"], 7: ["07_01"], 9: ["09_01"], 5: ["05_18"]}
PARENT = [-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14]
JOINTS = ["Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
          "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
BONES = ["%s>%s" % (JOINTS[PARENT[c]], JOINTS[c]) for c in range(1, 16)]
CHEST = range(3, 10)  # joints read in the chest frame (pose_error.hpp kChestJoint0 = 3, kChestJoints = 7)
SAMPLE = 3000
rng = np.random.default_rng(1)


def feats(path):
    out = os.path.join(WORK, "feat", os.path.basename(path)[:-4] + ".npy")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    if not os.path.exists(out):
        subprocess.run(["nice", KATA, "features", "--bvh", path, "--preset", "cmu", "--first-frame", "1", "--out", out],
                       check=True, stdout=subprocess.DEVNULL)
    return np.load(out).astype(np.float64)


def unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-9, v / np.maximum(n, 1e-12), 0.0)


def bone_dirs(x):
    """Frames x 15 x 3: unit bone directions as pose_error.cpp's bone() reads them."""
    p = np.zeros((len(x), 16, 3))
    p[:, 1:] = x[:, :45].reshape(-1, 15, 3)
    fy = unit(p[:, 2] - p[:, 1])
    fx = p[:, 4] - p[:, 7]
    fx = unit(fx - (fx * fy).sum(1, keepdims=True) * fy)
    fz = np.cross(fx, fy)
    fr = p.copy()
    for j in CHEST:
        v = p[:, j] - p[:, 2]
        fr[:, j] = np.stack([(v * fx).sum(1), (v * fy).sum(1), (v * fz).sum(1)], 1)
    d = np.zeros((len(x), 15, 3))
    for c in range(1, 16):
        start = np.zeros_like(fr[:, c]) if (c in CHEST and PARENT[c] == 2) else fr[:, PARENT[c]]
        d[:, c - 1] = unit(fr[:, c] - start)
    return d


def angles(da, db):
    s = np.linalg.norm(np.cross(da, db), axis=-1)
    return np.degrees(np.arctan2(s, (da * db).sum(-1)))


def same_motion():
    """[(motion, teacher, student, frames x 15 angles)] over w_turned.TEST_SAME."""
    out = []
    os.makedirs(os.path.join(WORK, "align"), exist_ok=True)
    for t, s in w_turned.TEST_SAME:
        path = os.path.join(WORK, "align", "%s_vs_%s.csv" % (t, s))
        if not os.path.exists(path):
            subprocess.run(["nice", KATA, "score", "--model", MODEL, "--teacher", os.path.join(DATA, t + ".bvh"),
                            "--student", os.path.join(DATA, s + ".bvh"), "--preset", "cmu", "--first-frame", "1",
                            "--align", "dtw", "--out", path], check=False, stdout=subprocess.DEVNULL)
        rows = [r for r in csv.DictReader(l for l in open(path) if not l.startswith("#")) if r["state"] == "scoring"]
        a = np.array([int(r["frame"]) - 1 for r in rows])  # features row = BVH frame - 1 (part_fix.py)
        b = np.array([int(r["matched_teacher_frame"]) - 1 for r in rows])
        ds, dt = bone_dirs(feats(os.path.join(DATA, s + ".bvh"))), bone_dirs(feats(os.path.join(DATA, t + ".bvh")))
        out.append((MOTION.get(t, "jump"), t, s, angles(ds[a], dt[b])))
    return out


def online(teacher, student):
    """Frames x 15 angles of `kata score`'s own online alignment (as a lesson scores; scoring frames)."""
    path = os.path.join(WORK, "online", "%s_vs_%s.csv" % (os.path.basename(teacher)[:-4], os.path.basename(student)[:-4]))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    if not os.path.exists(path):
        subprocess.run(["nice", KATA, "score", "--model", MODEL, "--teacher", teacher, "--student", student, "--preset",
                        "cmu", "--first-frame", "1", "--out", path], check=False, stdout=subprocess.DEVNULL)
    rows = [r for r in csv.DictReader(l for l in open(path) if not l.startswith("#")) if r["state"] == "scoring"]
    a = np.array([int(r["frame"]) - 1 for r in rows], dtype=int)
    b = np.array([int(r["matched_teacher_frame"]) - 1 for r in rows], dtype=int)
    return angles(bone_dirs(feats(student))[a], bone_dirs(feats(teacher))[b])


def turned(data):
    """[(motion, clip, joint, degrees, frames x 15 angles)]: each turned copy against its excerpt."""
    out = []
    for cs in w_turned.TURN_CLIPS.values():
        for c in cs:
            d0 = bone_dirs(feats(os.path.join(data, "x%s.bvh" % c)))
            for j, _ in w_turned.TURNS:
                for g in w_turned.ANGLES:
                    d1 = bone_dirs(feats(os.path.join(data, w_turned.turned_name(c, j, g))))
                    n = min(len(d0), len(d1))
                    out.append((MOTION[c], c, j, g, angles(d1[1:n], d0[1:n])))  # row 0: no stencil history
    return out


def dominated_share(cross, tur):
    """Share of (cross, turned) row combinations where cross >= turned on every bone."""
    hit = 0
    for e in tur:
        hit += np.count_nonzero((cross >= e).all(1))
    return hit / float(len(cross) * len(tur))


def sub(x, n):
    return x if len(x) <= n else x[rng.choice(len(x), n, replace=False)]


AGG = [("mean", lambda e: e.mean(0)), ("median", lambda e: np.median(e, 0)), ("P90", lambda e: np.percentile(e, 90, 0))]


def main():
    os.makedirs(OUT, exist_ok=True)
    data = w_turned.data_dir()
    same = same_motion()
    tur = turned(data)
    motions = ["walk", "run", "dance"]
    L = []
    w = L.append
    w("# Item 5 against the 45-degree catch: per-bone dominance\n")
    w("`/usr/bin/python3 docs/model/target_conflict.py build/bin/kata ../shared/data/cmu models/default.kata "
      "docs/model/eval-target-conflict` (work files cached in build/dominance).\n")
    w("Bones: the 15 the shipped worst part's joint angle takes its maximum over (pose_error.cpp part_error; "
      "parent>child, CMU names; head and arms in the chest frame, the rest in GPD's local frame). "
      "Same motion: calibrate.py's same-motion pairs, DTW-aligned scoring frames of `kata score --align dtw` "
      "(walk, run: another subject; dance: another take of subject 5; jump: subject 1 against 2). Turned: "
      "the ten joints of the balance table at +-30 and +-45 degrees on a 600-frame excerpt "
      "(02_01, 07_01 walk; 09_01 run; 05_18 dance), frame for frame.\n")
    w("## Same-motion pairs\n")
    w("| motion | teacher | student | frames | median max-bone angle | max-bone > 30 | max-bone > 45 |")
    w("|---|---|---|---|---|---|---|")
    for m, t, s, e in same:
        mx = e.max(1)
        w("| %s | %s | %s | %d | %.1f | %.2f | %.2f |" % (m, t, s, len(e), np.median(mx), (mx > 30).mean(), (mx > 45).mean()))
    w("\n## Frame level: share of (same-motion frame pair, turned frame pair) combinations where the "
      "same-motion pair is >= on every bone\n")
    w("Each side a random sample of at most %d frame pairs per cell (seed 1). 'every copy': the same-motion "
      "pairs of the row's motion against every turned copy at that angle.\n" % SAMPLE)
    w("| motion | same-motion frames | turned at 45: same motion's copies | turned at 30: same motion | "
      "turned at 45: every copy |")
    w("|---|---|---|---|---|")
    fl = {}
    for m in motions + ["all"]:
        cross = np.concatenate([e for mm, _, _, e in same if mm == m or m == "all"])
        cs = sub(cross, SAMPLE)
        cells = []
        for g, own in ((45, True), (30, True), (45, False)):
            tt = np.concatenate([e for mm, _, _, gg, e in tur if abs(gg) == g and (mm == m or not own or m == "all")])
            cells.append(dominated_share(cs, sub(tt, SAMPLE)))
        fl[m] = cells
        w("| %s | %d | %.4f | %.4f | %.4f |" % (m, len(cross), cells[0], cells[1], cells[2]))
    w("\nPer turned joint (all motions pooled, same-motion frame pairs of every motion against that joint's "
      "copies at +-45 of every motion):\n")
    w("| joint turned | turned bone(s) (median angle > 5 deg) | median angle of the most turned bone | "
      "same-motion frames >= on every bone |")
    w("|---|---|---|---|")
    allc = sub(np.concatenate([e for _, _, _, e in same]), SAMPLE)
    for j, _ in w_turned.TURNS:
        tt = np.concatenate([e for _, _, jj, gg, e in tur if jj == j and abs(gg) == 45])
        med = np.median(tt, 0)
        w("| %s | %s | %.1f | %.4f |" % (j, ", ".join(BONES[k] for k in np.where(med > 5)[0]) or "none",
                                          med.max(), dominated_share(allc, sub(tt, SAMPLE))))
    w("\n## Clip level: same-motion pairs whose per-bone profile over the clip is >= a 45-degree copy's on every bone\n")
    w("Per clip pair, each bone's angle aggregated over the frames (mean, median, 90th percentile); a "
      "same-motion pair counts when it dominates at least one 45-degree copy (any clip, any joint) and "
      "its copies count is how many of the copies it dominates.\n")
    w("| aggregate | motion | same-motion pairs | pairs dominating >= 1 copy at 45 | (pair, copy at 45) "
      "combinations dominated | of those, copy of the same motion |")
    w("|---|---|---|---|---|---|")
    t45 = [(mm, c, j, g, e) for mm, c, j, g, e in tur if abs(g) == 45]
    clip = {}
    for an, f in AGG:
        tp = np.array([f(e) for *_, e in t45])
        tm = [mm for mm, *_ in t45]
        for m in motions + ["jump", "all"]:
            ps = [(t, s, f(e)) for mm, t, s, e in same if mm == m or m == "all"]
            if not ps:
                continue
            dom = [np.array([(p >= q).all() for q in tp]) for _, _, p in ps]
            n1 = sum(d.any() for d in dom)
            comb = sum(d.sum() for d in dom)
            own = sum(sum(d[k] for k in range(len(tp)) if tm[k] == mm) for d, (mm, *_) in
                      zip(dom, [x for x in same if x[0] == m or m == "all"]))
            clip[(an, m)] = (len(ps), n1, comb)
            w("| %s | %s | %d | %d | %d of %d | %d |" % (an, m, len(ps), n1, comb, len(ps) * len(tp), own))
    w("\nThe dominated copies, per clip-level aggregate (mean):\n")
    w("| same-motion pair | copies at 45 it dominates (clip, joint, degrees) |\n|---|---|")
    tp = np.array([e.mean(0) for *_, e in t45])
    for m, t, s, e in same:
        p = e.mean(0)
        hits = ["%s %s %+d" % (c, j, g) for (mm, c, j, g, _), q in zip(t45, tp) if (p >= q).all()]
        if hits:
            w("| %s vs %s (%s) | %s |" % (t, s, m, ", ".join(hits)))
    w("\n## Two monotone clip-level measures, same-motion pairs against the copies\n")
    w("A: the largest bone's clip mean, max_b mean_t angle[t, b] (a score of the clip's per-bone means); "
      "B: the clip mean of each frame's largest bone, mean_t max_b angle[t, b] (the shape of the shipped "
      "total: the worst bone per frame, averaged over the scoring frames). A threshold separates the two "
      "targets when every same-motion pair is below every copy at 45.\n")
    data = os.path.join(WORK, "data")
    on_same = [(m, t, st, online(os.path.join(DATA, t + ".bvh"), os.path.join(DATA, st + ".bvh"))) for m, t, st, _ in same]
    on_tur = [(m, c, j, g, online(os.path.join(data, "x%s.bvh" % c), os.path.join(data, w_turned.turned_name(c, j, g))))
              for m, c, j, g, _ in tur]
    w("Alignment 'DTW / frame for frame': the same-motion pairs by `kata score --align dtw`, the copies frame for "
      "frame (as above); 'online': both by `kata score`'s own online alignment (as a lesson scores them: the "
      "student's frame against its matched teacher frame), scoring frames only.\n")
    w("| measure | alignment | motion | same-motion pairs: median (highest; pair) | copies at 30: lowest, median | copies at 45: "
      "lowest (copy), median | same-motion pairs above the lowest copy at 45 |")
    w("|---|---|---|---|---|---|---|")
    for name, f, al, SM, TU, m in [(n, f, al, SM, TU, m) for n, f in (("A", lambda e: e.mean(0).max()),
                                                             ("B", lambda e: e.max(1).mean()))
                                   for al, SM, TU in (("DTW / frame for frame", same, tur), ("online", on_same, on_tur))
                                   for m in ("all", "walk", "run", "dance", "jump")]:
        sv = [(f(e), "%s vs %s" % (t, s)) for mm, t, s, e in SM if m in ("all", mm)]
        v30 = [f(e) for *_, g, e in TU if abs(g) == 30]
        v45 = sorted((f(e), "%s %s %+d" % (c, j, g)) for _, c, j, g, e in TU if abs(g) == 45)
        hi = max(sv)
        w("| %s | %s | %s | %.1f (%.1f; %s) | %.1f, %.1f | %.1f (%s), %.1f | %d of %d |" % (
            name, al, m, np.median([x for x, _ in sv]), hi[0], hi[1], min(v30), np.median(v30), v45[0][0], v45[0][1],
            np.median([x for x, _ in v45]), sum(x >= v45[0][0] for x, _ in sv), len(sv)))
    w("\nClip level with the online alignment (both sides): same-motion pairs whose per-bone profile dominates "
      "at least one copy at 45, and the (pair, copy) combinations dominated:\n")
    w("| aggregate | walk | run | dance | jump | all: pairs | all: combinations |\n|---|---|---|---|---|---|---|")
    on45 = [x for x in on_tur if abs(x[3]) == 45]
    for an, f in AGG:
        tp = np.array([f(e) for *_, e in on45])
        dom = [(mm, np.array([(f(e) >= q).all() for q in tp])) for mm, _, _, e in on_same]
        per = ["%d of %d" % (sum(d.any() for mm, d in dom if mm == m), sum(1 for mm, _ in dom if mm == m))
               for m in ("walk", "run", "dance", "jump")]
        w("| %s | %s | %d of %d | %d of %d |" % (an, " | ".join(per), sum(d.any() for _, d in dom), len(dom),
                                               sum(d.sum() for _, d in dom), len(dom) * len(tp)))
    tp = np.array([e.mean(0) for *_, e in on45])
    for m, t, st, e in on_same:
        hits = ["%s %s %+d" % (c, j, g) for (_, c, j, g, _), q in zip(on45, tp) if (e.mean(0) >= q).all()]
        if hits:
            w("- online, per-bone mean: %s vs %s (%s) dominates %d copies at 45: %s" % (t, st, m, len(hits), ", ".join(hits)))
    w("\n## Per bone: same-motion angle against the turned bone's angle\n")
    w("Same-motion: quantiles over every aligned frame pair (all motions). Turned: per joint, the median "
      "angle (over the frames of its copies) of the bone most moved by the turn.\n")
    w("| bone | same-motion P10 | P50 | P90 | P99 | turned at 30: median (copies whose most moved bone this is) | "
      "turned at 45 |")
    w("|---|---|---|---|---|---|---|")
    cross = np.concatenate([e for _, _, _, e in same])
    for k, b in enumerate(BONES):
        q = np.percentile(cross[:, k], [10, 50, 90, 99])
        cells = []
        for g in (30, 45):
            v = [np.median(e[:, k]) for *_, gg, e in tur if abs(gg) == g and np.median(e, 0).argmax() == k]
            cells.append("%.1f (%d)" % (np.median(v), len(v)) if v else "-")
        w("| %s | %.1f | %.1f | %.1f | %.1f | %s | %s |" % ((b,) + tuple(q) + tuple(cells)))
    mx = cross.max(1)
    w("\nSame-motion frame pairs whose largest bone angle exceeds 30 / 45 degrees: %.3f / %.3f (of %d; per "
      "motion: %s). The turned copies' most moved bone, median over frames: at 30 degrees %.1f, at 45 %.1f "
      "(median over copies).\n" % ((mx > 30).mean(), (mx > 45).mean(), len(mx), "; ".join(
          "%s %.3f / %.3f" % (m, (np.concatenate([e for mm, _, _, e in same if mm == m]).max(1) > 30).mean(),
                              (np.concatenate([e for mm, _, _, e in same if mm == m]).max(1) > 45).mean())
          for m in motions), np.median([np.median(e, 0).max() for *_, g, e in tur if abs(g) == 30]),
          np.median([np.median(e, 0).max() for *_, g, e in tur if abs(g) == 45])))
    open(os.path.join(OUT, "target_conflict.md"), "w").write("\n".join(L) + "\n")
    print("\n".join(L))


if __name__ == "__main__":
    main()
