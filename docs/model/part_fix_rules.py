#!/usr/bin/python3
"""Which rule for the part to fix can agree with geometry on real pairs (issue 34 item 3): replays the
scorer's averaging and hysteresis (sdk/src/metric/scorer.cpp Scorer::update_part_to_fix) in Python on the
per-frame CSVs of `part_fix.py measure`, with other ranking keys and other hysteresis, and counts the
pairs whose part named on the most scoring frames is in geometry's top 2 (part_fix.py's judge).

    /usr/bin/python3 docs/model/part_fix_rules.py [build/bin/kata] [../shared/data/cmu] [models/default.kata]

The offset key is the local-frame mean joint distance of each part per frame (part_fix.py's geometry,
at the matched frame), which is the scorer's PartError::offset since 2026-12-04 (before, the head and arms
were read in the chest frame). The replay of the product's rule (`product` below: the lowest averaged part,
or a part below good within kOffsetBand = 20 points of it with a larger averaged offset; 0.5 s average,
0.5 s hold) must give part_fix.py's own count; the replay of the old rule (`lowest score`, hold 0.5 s)
gave 66 of 98, part_fix.py's count before. Turned-joint figures need the scorer (balance-table,
tests/metric/test_balance.cpp); scores.md "The part to fix" gives both.
"""
import csv, os, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.argv = [sys.argv[0], "measure"] + sys.argv[1:4]
sys.path.insert(0, HERE)
import part_fix as P  # noqa: E402  (its argv parsing reads KATA, DATA, MODEL from the arguments above)

GOOD = 92.0  # the model's good_score (scores.md "The coaching total")


def load():
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


def replay(p, key, tau=0.5, hold=0.5, margin=None):
    """The part named per frame: exponential averages over tau s of the part scores, the offsets and the
    total; candidate = argmax key(scores, offsets) while a part or the total is below good; shown as in
    the scorer (at once when nothing is shown, else after the candidate held `hold` s), or, with a
    margin, when the candidate's key exceeds the shown part's by that fraction."""
    sp = sg = st = prev = None
    shown, cand, since, out = -1, -1, 0.0, []
    for i in range(len(p["t"])):
        k = 0.0 if prev is None or tau <= 0 else np.exp(-(p["t"][i] - prev) / tau)
        sp = p["ps"][i] if sp is None else p["ps"][i] + k * (sp - p["ps"][i])
        sg = p["geo"][i] if sg is None else p["geo"][i] + k * (sg - p["geo"][i])
        st = p["total"][i] if st is None else p["total"][i] + k * (st - p["total"][i])
        prev = p["t"][i]
        v = key(sp, sg)
        c = int(np.argmax(v)) if (sp.min() < GOOD or st < GOOD) else -1
        if margin is not None:
            if c < 0: shown = -1
            elif shown < 0 or v[c] > v[shown] * (1 + margin): shown = c
        else:
            if c != cand: cand, since = c, p["t"][i]
            if shown < 0 and cand >= 0: shown = cand
            elif cand != shown and p["t"][i] - since >= hold - 1e-9: shown = cand
        out.append(shown)
    out = np.array(out)
    n = np.bincount(out[out >= 0], minlength=5)
    named = int(n.argmax()) if n.sum() else int(np.argmin(p["ps"].mean(0)))
    return named in p["rank"][:2]


def lowest(sp, sg): return -sp  # the product: lowest averaged part score (ties by offset: none occur here)


def offset(sp, sg): return sg


def within(n):
    return lambda sp, sg: np.where(sp <= sp.min() + n, sg, -1.0)


def band_below_good(n, good=GOOD):
    """The lowest part, or a part below good within n points of it, by the larger offset."""
    return lambda sp, sg: np.where((sp <= sp.min() + n) & ((sp < good) | (sp <= sp.min())), sg, -1.0)


def mode_of_frames(pairs, per_frame):
    return sum(int(np.bincount(per_frame(p), minlength=5).argmax()) in p["rank"][:2] for p in pairs)


def main():
    pairs = load()
    n = len(pairs)
    keys = [("lowest score", lowest), ("largest offset", offset), ("offset within 20 of lowest", within(20)),
            ("offset within 30 of lowest", within(30)), ("product: offset within 20 of lowest, below good", band_below_good(20)),
            ("offset within 30 of lowest, below good", band_below_good(30))]
    print("Pairs in geometry's top 2 of %d (first 22: subject 9's runs, held out)\n" % n)
    print("| ranking \\ average, hysteresis | " + " | ".join(
        ["0.5 s, hold 0.5 s (the product's)", "0.5 s, hold 0.25 s", "0.5 s, no hold", "0.25 s, no hold",
         "0.5 s, margin 10 %", "0.5 s, margin 20 %"]) + " |")
    print("|---|" + "---|" * 6)
    for name, key in keys:
        cells = [sum(replay(p, key, 0.5, 0.5) for p in pairs), sum(replay(p, key, 0.5, 0.25) for p in pairs),
                 sum(replay(p, key, 0.5, 0.0) for p in pairs), sum(replay(p, key, 0.25, 0.0) for p in pairs),
                 sum(replay(p, key, 0.5, margin=0.1) for p in pairs), sum(replay(p, key, 0.5, margin=0.2) for p in pairs)]
        print("| %s | %s |" % (name, " | ".join("%d (%.1f %%)" % (c, 100.0 * c / n) for c in cells)))
    print("\nNo average, no gate, no hysteresis, the mode over frames: largest offset %d, lowest score %d" % (
        mode_of_frames(pairs, lambda p: np.argmax(p["geo"], 1)), mode_of_frames(pairs, lambda p: np.argmin(p["ps"], 1))))


if __name__ == "__main__":
    main()
