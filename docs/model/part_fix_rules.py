#!/usr/bin/python3
"""Which rule for the part to fix can agree with geometry on real pairs and still name a
turned joint: replays the scorer's averaging and hysteresis (sdk/src/metric/scorer.cpp
Scorer::update_part_to_fix) in Python, with other ranking keys and holds, on two sets of per-frame CSVs:
the 98 real pairs of `part_fix.py measure` (`--align dtw`; counted: pairs whose part named on the most
scoring frames is in geometry's top 2, part_fix.py's judge) and the 120 turned copies of
`part_fix_turned.py` (the balance test's 3 s of 02_01, 05_18, 09_01, ten joints at +-30 and +-45 deg,
online alignment; counted: the share of scoring frames naming the turned joint's part).

    /usr/bin/python3 docs/model/part_fix_rules.py [build/bin/kata] [../shared/data/cmu] [models/default.kata] [loso]

With `loso`, the choice of the band, hold and torso weight is checked leave-one-subject-out: per subject,
the grid point (band 98-99.5 x hold 0.25-0.35 s x weight 3-4) with the most pairs in top 2 among the pairs
the subject takes no part in, of those that keep every turned row at +-30 >= 0.70, scored on its own pairs.

The offset key is the local-frame mean joint distance of each part per frame at the matched frame
(part_fix.py's geometry), which is the scorer's PartError::offset. The averages are the scorer's: exponential
over 0.5 s, normalised by the weights summed since the first scoring frame. The replay of the shipped rule
(`shipped` below) gives part_fix.py's own count (85 of 98) and the turned shares of the CSVs the scorer
wrote (part_fix_turned.py prints them). scores.md "The part to fix" gives the tables this prints.
"""
import os, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
LOSO = len(sys.argv) > 4 and sys.argv[4] == "loso"
del sys.argv[4:]
import part_fix_turned as T  # noqa: E402  (reads KATA, DATA, MODEL from the arguments; imports part_fix)
import part_fix as P  # noqa: E402
import csv  # noqa: E402

GOOD = 92.0  # the model's good_score (scores.md "The coaching total")
TORSO = 0


def load_pairs():
    os.makedirs(P.WORK, exist_ok=True)
    pairs = []
    for t, s in P.HELD_OUT_PAIRS + P.TRAIN_PAIRS:
        p = P.score_pair(t, s)  # writes the CSV if missing
        path = os.path.join(P.WORK, "%s_vs_%s_%s.csv" % (t, s, P.model_key()))
        rows = [r for r in csv.DictReader(open(path)) if r["state"] == "scoring"]
        p["t"] = np.array([float(r["time"]) for r in rows])
        p["total"] = np.array([float(r["score"]) for r in rows])
        p["rank"] = P.judge(p)["rank"]
        pairs.append(p)
    return pairs


def replay(p, rank, hold, tau=0.5):
    """The part shown per frame: normalised exponential averages over tau s of the part scores, offsets
    and total; candidate = rank(scores, offsets) while a part or the total is below good; shown at once
    when nothing is shown, else after the candidate has held `hold` s."""
    sp, sg, st, w, prev = np.zeros(5), np.zeros(5), 0.0, 0.0, None
    shown, cand, since = -1, -1, 0.0
    out = np.empty(len(p["t"]), int)
    for i in range(len(p["t"])):
        k = 0.0 if prev is None or tau <= 0 else np.exp(-(p["t"][i] - prev) / tau)
        w = 1.0 + k * w
        sp += (p["ps"][i] - sp) / w
        sg += (p["geo"][i] - sg) / w
        st += (p["total"][i] - st) / w
        prev = p["t"][i]
        c = rank(sp, sg) if (sp.min() < GOOD or st < GOOD) else -1
        if c != cand: cand, since = c, p["t"][i]
        if shown < 0 and cand >= 0: shown = cand
        elif cand != shown and p["t"][i] - since >= hold - 1e-9: shown = cand
        out[i] = shown
    return out


def band(admit, width, torso_weight=1.0, torso_below=GOOD):
    """The lowest averaged part, or a part scoring below `admit` within `width` points of it with a larger
    offset; the torso's offset weighed `torso_weight` times while the torso scores below `torso_below`."""
    def rank(sp, sg):
        low = int(np.argmin(sp))
        g = sg.copy()
        if sp[TORSO] < torso_below: g[TORSO] *= torso_weight
        c = low
        for q in range(5):
            if q != low and sp[q] < admit and sp[q] <= sp[low] + width and g[q] > g[c]: c = q
        return c
    return rank


def lowest(sp, sg): return int(np.argmin(sp))


def offset(sp, sg): return int(np.argmax(sg))


def real_count(pairs, rank, hold):
    n = 0
    for p in pairs:
        out = replay(p, rank, hold)
        f = np.bincount(out[out >= 0], minlength=5)
        named = int(f.argmax()) if f.sum() else int(np.argmin(p["ps"].mean(0)))
        n += named in p["rank"][:2]
    return n


def turned_shares(copies, rank, hold):
    return {(c["clip"], c["joint"], c["deg"]): float(np.mean(replay(c, rank, hold) == c["part"])) for c in copies}


RULES = [
    ("lowest score", lowest, 0.5),
    ("largest offset", offset, 0.5),
    ("offset below good (92) within 20 of the lowest, hold 0.5 s (2026-12-04)", band(GOOD, 20), 0.5),
    ("the same, hold 0.3 s", band(GOOD, 20), 0.3),
    ("below 99 within 30, hold 0.3 s", band(99, 30), 0.3),
    ("below 99 within 30, hold 0.25 s", band(99, 30), 0.25),
    ("below 98 within 30, torso x 3.25 always, hold 0.3 s", band(98, 30, 3.25, 101), 0.3),
    ("below 99 within 30, torso x 3.25 always, hold 0.3 s", band(99, 30, 3.25, 101), 0.3),
    ("below 99 within 30, torso x 2 below good, hold 0.3 s", band(99, 30, 2.0), 0.3),
    ("**below 99 within 30, torso x 3.25 below good, hold 0.3 s (shipped)**", band(99, 30, 3.25), 0.3),
    ("below 99 within 30, torso x 3.25 below good, hold 0.25 s", band(99, 30, 3.25), 0.25),
    ("below 99 within 30, torso x 3.25 below good, hold 0.35 s", band(99, 30, 3.25), 0.35),
    ("below 99 within 30, torso x 3.25 below good, hold 0.5 s", band(99, 30, 3.25), 0.5),
    ("below 99.5 within 30, torso x 3.25 below good, hold 0.25 s", band(99.5, 30, 3.25), 0.25),
    ("below 98.5 within 30, torso x 3.25 below good, hold 0.3 s", band(98.5, 30, 3.25), 0.3),
]


def main():
    pairs, copies = load_pairs(), T.load()
    print("| rule (0.5 s normalised average) | real pairs in top 2 (of %d) | turned +-30: lowest share (rows < 0.70 of 60) "
          "| turned +-45: lowest share (rows < 0.70 of 60) |" % len(pairs))
    print("|---|---|---|---|")
    for name, rank, hold in RULES:
        sh = turned_shares(copies, rank, hold)
        cells = []
        for deg in (30, 45):
            v = {k: s for k, s in sh.items() if abs(k[2]) == deg}
            worst = min(v, key=v.get)
            cells.append("%.2f (%s %s %+d); %d" % (v[worst], worst[0], worst[1], worst[2], sum(s < 0.70 for s in v.values())))
        print("| %s | %d | %s | %s |" % (name, real_count(pairs, rank, hold), cells[0], cells[1]), flush=True)


def hits(pairs, rank, hold):
    out = []
    for p in pairs:
        shown = replay(p, rank, hold)
        f = np.bincount(shown[shown >= 0], minlength=5)
        out.append((int(f.argmax()) if f.sum() else int(np.argmin(p["ps"].mean(0)))) in p["rank"][:2])
    return np.array(out)


def loso():
    pairs, copies = load_pairs(), T.load()
    grid = [(a, h, w) for a in (98, 98.5, 99, 99.5) for h in (0.25, 0.3, 0.35) for w in (3.0, 3.25, 3.5, 4.0)]
    res = {}
    for a, h, w in grid:
        sh = turned_shares(copies, band(a, 30, w), h)
        res[(a, h, w)] = (min(v for k, v in sh.items() if abs(k[2]) == 30) >= 0.70, hits(pairs, band(a, 30, w), h))
    for sub in (2, 5, 7, 9):
        mine = np.array([sub in (P.subject(p["teacher"]), P.subject(p["student"])) for p in pairs])
        best = max((k for k in grid if res[k][0]), key=lambda k: (res[k][1][~mine].sum(), -abs(k[1] - 0.3)))
        print("subject %d: chosen on the %d other pairs: band %g, hold %g s, weight %g (%d in top 2); on its own %d "
              "pairs: %d" % (sub, (~mine).sum(), best[0], best[1], best[2], res[best][1][~mine].sum(), mine.sum(),
                             res[best][1][mine].sum()))


if __name__ == "__main__":
    loso() if LOSO else main()
