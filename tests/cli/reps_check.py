#!/usr/bin/python3
"""Repetitions, tempo and range of motion of `kata score --reps` against truths computed here,
from the BVH files themselves, never by kata (docs/coach/repetitions.md has the figures):

  synthetic   one gait cycle cut from a CMU walk (cut at the left foot passing the right one),
              repeated 10 times, each time-stretched by its own factor in 0.8..1.25, one with the
              left knee turned 45 degrees: exactly 10 counted, tempo within 5 % of each factor, the
              turned one scoring <= 50 with the left leg (knee) named;
  rom         each repetition's range of motion of the eight joint angles, and the teacher's, against
              numpy forward kinematics of the same BVH: within 2 degrees;
  partial     3 cycles, half a cycle, a pause, something else (a dance), then 3 cycles again:
              a partial repetition reported, the count going on to 6;
  natural     walks and runs of every subject with walks or runs (2, 5, 7, 9) against one gait
              cycle of another subject's clip: the count equals the gait cycles found from the feet
              (the left foot passing the right one along the hips' facing direction), within one.

  reps_check.py KATA_CLI SOURCE_DIR [--verbose]
"""
import csv
import json
import os
import re
import signal
import shutil
import subprocess
import sys
import tempfile
import urllib.request

import numpy as np

KATA, SRC = sys.argv[1], sys.argv[2]
VERBOSE = "--verbose" in sys.argv
MODEL = os.path.join(SRC, "models", "default.kata")
CMU = [os.path.join(SRC, "data", "cmu"), os.path.join(SRC, "tests", "data", "cmu")]
ROM_JOINTS = ["left_knee", "right_knee", "left_hip", "right_hip",
              "left_elbow", "right_elbow", "left_shoulder", "right_shoulder"]
COLUMNS = ["rep", "start_time", "end_time", "tempo", "score", "part_to_fix", "cue", "partial"] + \
    [c for j in ROM_JOINTS for c in ("range_" + j, "range_" + j + "_teacher")]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def clip_path(name):
    for d in CMU:
        p = os.path.join(d, name + ".bvh")
        if os.path.exists(p):
            return p
    raise SystemExit(f"no {name}.bvh in {CMU}")


class Bvh:
    """A BVH file: its hierarchy lines (kept verbatim), joints, and the motion as an array."""

    def __init__(self, path):
        lines = open(path).read().splitlines()
        self.names, self.parents, self.offsets, self.channels = [], [], [], []
        stack, i = [], 0
        while not lines[i].strip().startswith("MOTION"):
            t = lines[i].split()
            if t and t[0] in ("ROOT", "JOINT"):
                self.names.append(t[1])
                self.parents.append(stack[-1] if stack else -1)
                self.offsets.append(None)
                self.channels.append([])
                stack.append(len(self.names) - 1)
                current = len(self.names) - 1
            elif t and t[0] == "End":
                stack.append(None)
                current = None
            elif t and t[0] == "OFFSET" and current is not None and self.offsets[current] is None:
                self.offsets[current] = np.array([float(v) for v in t[1:4]])
            elif t and t[0] == "CHANNELS":
                self.channels[current] = t[2:2 + int(t[1])]
            elif t and t[0] == "}":
                stack.pop()
                current = stack[-1] if stack else None
            i += 1
        self.header = lines[:i]
        self.frame_time = float(lines[i + 2].split()[-1])
        self.motion = np.array([[float(v) for v in l.split()] for l in lines[i + 3:] if l.strip()])
        self.column = []  # first motion column of each joint
        c = 0
        for ch in self.channels:
            self.column.append(c)
            c += len(ch)

    def col(self, joint, channel):
        j = self.names.index(joint)
        return self.column[j] + self.channels[j].index(channel)

    def positions(self, motion=None):
        """World positions (frames x joints x 3) by forward kinematics: each joint's rotation is
        the product of its channels' rotations in the order listed (CMU: Z, Y, X)."""
        m = self.motion if motion is None else motion
        f = len(m)
        pos = np.zeros((f, len(self.names), 3))
        rot = np.zeros((f, len(self.names), 3, 3))
        for j, chans in enumerate(self.channels):
            r = np.tile(np.eye(3), (f, 1, 1))
            p = np.tile(self.offsets[j], (f, 1))
            for k, ch in enumerate(chans):
                v = m[:, self.column[j] + k]
                if ch.endswith("position"):
                    p[:, "XYZ".index(ch[0])] += v
                    continue
                a = np.radians(v)
                c, s = np.cos(a), np.sin(a)
                one, zero = np.ones(f), np.zeros(f)
                if ch[0] == "X":
                    q = np.stack([one, zero, zero, zero, c, -s, zero, s, c], 1)
                elif ch[0] == "Y":
                    q = np.stack([c, zero, s, zero, one, zero, -s, zero, c], 1)
                else:
                    q = np.stack([c, -s, zero, s, c, zero, zero, zero, one], 1)
                r = r @ q.reshape(f, 3, 3)
            parent = self.parents[j]
            if parent < 0:
                pos[:, j], rot[:, j] = p, r
            else:
                pos[:, j] = pos[:, parent] + np.einsum("fab,fb->fa", rot[:, parent], p)
                rot[:, j] = rot[:, parent] @ r
        return pos

    def write(self, path, motion):
        with open(path, "w") as out:
            out.write("\n".join(self.header) + "\nMOTION\n")
            out.write(f"Frames: {len(motion)}\nFrame Time: {self.frame_time:.7f}\n")
            for row in motion:
                out.write(" ".join(f"{v:.6f}" for v in row) + "\n")


def joint_angles(bvh, pos):
    """The eight angles (degrees) per frame, as docs/coach/repetitions.md defines them, from the
    CMU joints of the GPD preset (spec gpd-v1.md section 1)."""
    J = {n: pos[:, bvh.names.index(n)] for n in bvh.names}

    def angle(u, v):
        c = np.sum(u * v, 1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        return np.degrees(np.arccos(np.clip(c, -1, 1)))

    trunk = J["Neck1"] - J["Hips"]
    out = []
    for side in ("Left", "Right"):  # knees
        out.append(angle(J[side + "UpLeg"] - J[side + "Leg"], J[side + "Foot"] - J[side + "Leg"]))
    for side in ("Left", "Right"):  # hips
        out.append(angle(trunk, J[side + "Leg"] - J[side + "UpLeg"]))
    for side in ("Left", "Right"):  # elbows
        out.append(angle(J[side + "Arm"] - J[side + "ForeArm"], J[side + "Hand"] - J[side + "ForeArm"]))
    for side in ("Left", "Right"):  # shoulders
        out.append(angle(-trunk, J[side + "ForeArm"] - J[side + "Arm"]))
    return np.stack(out, 1)


def left_passes(bvh, pos):
    """Frames (from 1: frame 0 is the converter's T-pose) where the left foot passes the right one
    going forward along the hips' facing direction, with a hysteresis of 3 % of the leg."""
    J = lambda n: pos[:, bvh.names.index(n)]
    left = J("LeftUpLeg") - J("RightUpLeg")
    facing = np.stack([-left[:, 2], np.zeros(len(left)), left[:, 0]], 1)
    facing /= np.linalg.norm(facing, axis=1, keepdims=True)
    s = np.sum((J("LeftFoot") - J("RightFoot")) * facing, 1)
    leg = np.linalg.norm(bvh.offsets[bvh.names.index("LeftLeg")]) + np.linalg.norm(bvh.offsets[bvh.names.index("LeftFoot")])
    h = 0.03 * leg
    crossings, state = [], 0
    for f in range(1, len(s)):
        if s[f] < -h:
            state = -1
        elif s[f] > h and state == -1:
            # the crossing itself: the last frame at or below 0 before this one, and the next
            k = f
            while k > 1 and s[k - 1] > 0:
                k -= 1
            crossings.append(k)
            state = 1
    return crossings


def score(teacher, student, tmp, extra=()):
    reps = os.path.join(tmp, "reps.csv")
    cmd = [KATA, "score", "--model", MODEL, "--teacher", teacher, "--student", student, "--layout", "cmu",
           "--first-frame", "1", "--out", os.path.join(tmp, "frames.csv"), "--reps", reps, *extra]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{p.stdout}{p.stderr}")
    with open(reps) as f:
        header = f.readline().strip().split(",")
        check(header == COLUMNS, f"the CSV's columns are {header[:8]}...")
        rows = list(csv.DictReader(f, fieldnames=header))
    if VERBOSE:
        for r in rows:
            print("    ", {k: r[k] for k in COLUMNS[:8]})
    return rows


class Ran:
    def __init__(self, returncode, stdout):
        self.returncode, self.stdout = returncode, stdout


def coach_with_viewer(args):
    """Runs kata coach with its viewer on a free port; once the lesson is over (the report
    written), reads the viewer's whole event stream as a page that connects then would (setup,
    every frame, end) and stops the coach. Returns (the run, [(event, data)])."""
    proc = subprocess.Popen([KATA, "coach", "--port", "0", "--linger", "60", "--viewer-dir", os.path.join(SRC, "viewer"),
                             *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    out, port, events = [], None, []
    try:
        for line in proc.stdout:
            out.append(line)
            m = re.match(r"viewer: http://[^:]+:(\d+)/", line)
            port = int(m.group(1)) if m and port is None else port
            if line.startswith("report:"):
                break
        if port is not None and out and out[-1].startswith("report:"):
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/events", timeout=30) as stream:
                event, data = None, []
                for raw in stream:
                    line = raw.decode().rstrip("\n")
                    if line.startswith("event: "):
                        event = line[7:]
                    elif line.startswith("data: "):
                        data.append(line[6:])
                    elif not line and event:
                        events.append((event, json.loads("".join(data))))
                        if event == "end":
                            break
                        event, data = None, []
    finally:
        proc.send_signal(signal.SIGTERM)
        rest, _ = proc.communicate(timeout=60)
    return Ran(proc.returncode if any(e == "end" for e, _ in events) else -1, "".join(out) + rest), events


def check_counters(stdout, events, what):
    """The terminal's and the viewer's repetition counters end on the summary's count: the
    terminal's last line, the repetitions the viewer's events carried (frames and end) and the
    end event's count, with the last repetition (closed by the lesson's end) among them."""
    summary = re.search(r"^repetitions: (\d+) repetitions", stdout, re.M)
    lines = [l for l in stdout.splitlines() if l.startswith("[")]
    terminal = re.search(r"\| (\d+) repetitions \((\d+) partial\)", lines[-1]) if lines else None
    reps = [r for _, e in events for r in e.get("reps", [])]
    end = [e for name, e in events if name == "end"]
    done = [r["index"] for r in reps if not r["partial"]]
    n = int(summary.group(1)) if summary else -1
    check(summary is not None and terminal is not None and int(terminal.group(1)) == n,
          f"{what}: the terminal's last line counts {terminal.group(0) if terminal else None}, the summary {n}")
    check(len(end) == 1 and end[0].get("reps_done") == n and done == list(range(1, n + 1)),
          f"{what}: the viewer's events carry repetitions {done} and the end event counts "
          f"{end[0].get('reps_done') if end else None} (the summary: {n})")


def resample(motion, first, n, factor, rotation_cols):
    """One repetition: clip frames first..first+n (n frames, first+n the next cycle's start),
    played `factor` times as long, linearly interpolated (rotations unwrapped first)."""
    seg = motion[first:first + n + 1].copy()
    seg[:, rotation_cols] = np.degrees(np.unwrap(np.radians(seg[:, rotation_cols]), axis=0))
    m = int(round(factor * n))
    x = np.arange(m) * (n / m)
    i = np.minimum(np.floor(x).astype(int), n - 1)
    w = (x - i)[:, None]
    return seg[i] * (1 - w) + seg[i + 1] * w


def repeat(bvh, first, n, factors, turned=None, turn_col=None):
    """Repetitions of the cycle first..first+n, each stretched by its factor, the root carried on
    from where the last one ended (X and Z); `turned`: the index of the one with turn_col + 45."""
    rot_cols = [bvh.column[j] + k for j, chans in enumerate(bvh.channels) for k, ch in enumerate(chans)
                if ch.endswith("rotation")]
    root_xz = [bvh.col(bvh.names[0], "Xposition"), bvh.col(bvh.names[0], "Zposition")]
    step = bvh.motion[first + n, root_xz] - bvh.motion[first, root_xz]
    out = [bvh.motion[:1]]  # the T-pose frame, skipped by --first-frame 1
    for k, factor in enumerate(factors):
        rep = resample(bvh.motion, first, n, factor, rot_cols)
        rep[:, root_xz] += k * step
        if k == turned:
            rep[:, turn_col] += 45.0
        out.append(rep)
    return np.concatenate(out)


def main():
    tmp = tempfile.mkdtemp(prefix="kata-reps-")
    walk = Bvh(clip_path("02_01"))
    ft = walk.frame_time
    crossings = left_passes(walk, walk.positions())
    first, nxt = crossings[0], crossings[1]
    n = nxt - first
    print(f"02_01: left foot passes the right at frames {crossings}; the cycle: frames {first}..{nxt - 1} ({n * ft:.3f} s)")
    teacher = os.path.join(tmp, "cycle.bvh")
    walk.write(teacher, np.concatenate([walk.motion[:1], walk.motion[first:nxt]]))

    # Synthetic: 10 repetitions, each stretched, the 6th with the left knee turned 45 degrees.
    factors = [0.8, 1.25, 1.0, 0.9, 1.15, 1.05, 0.85, 1.2, 0.95, 1.1]
    turned = 5
    knee = walk.col("LeftLeg", "Xrotation")
    motion = repeat(walk, first, n, factors, turned, knee)
    student = os.path.join(tmp, "ten.bvh")
    walk.write(student, motion)
    rows = score(teacher, student, tmp)
    done = [r for r in rows if r["partial"] == "0"]
    # The same live in kata coach: the terminal's summary and the report's table. The last
    # repetition ends with the lesson (the end of the take), as kata score's ends with the clip.
    report, record, frames_csv = (os.path.join(tmp, f) for f in ("report.html", "lesson.npz", "lesson.csv"))
    p, events = coach_with_viewer(["--model", MODEL, "--teacher", teacher, "--student", student, "--reps", "--speed",
                                   "8", "--report", report, "--record", record, "--csv", frames_csv])
    check_counters(p.stdout, events, "coach")
    html = open(report).read() if os.path.exists(report) else ""
    table = html.split('<table class="reps">', 1)[-1].split("</table>", 1)[0] if '<table class="reps">' in html else ""
    summary = [l for l in p.stdout.splitlines() if l.startswith("repetitions")]
    check(p.returncode == 0 and "repetitions: 10 repetitions" in p.stdout and table.count("<tr><td>") == 10
          and html.count('<svg class="repplot"') == 3,
          "coach: 10 repetitions in the summary and the report's table, 3 plots (%s)" % summary)
    # The recording keeps them (array 'repetitions': index, partial, start, end, tempo, ...), and
    # the records' repetition column; a replay of it reports the same repetitions.
    if os.path.exists(record):
        z = np.load(record)
        reps = z["repetitions"] if "repetitions" in z.files else np.zeros((0, 27))
        ok = len(reps) == 10 and not reps[:, 1].any() and list(reps[:, 0]) == list(range(1, 11))
        errors = [abs(t / f - 1) for t, f in zip(reps[:, 4], factors)] if ok else [1.0]
        check(ok and max(errors) <= 0.05,
              "coach: the recording's 10 repetitions, tempo within 5 %% of each factor (largest error %.1f %%)"
              % (100 * max(errors)))
        live = z["repetition"] if "repetition" in z.files else np.zeros(0)
        check(len(live) and set(live.tolist()) - {0} == set(range(1, 11)) and (np.diff(live) >= 0).all(),
              "coach: the recording's repetition per frame goes 1..10 (%s)" % sorted(set(live.tolist())))
        with open(frames_csv) as f:
            head = f.readline().strip().split(",")
        check(head[-2:] == ["repetition", "repetition_progress"], "coach: --csv ends with %s" % head[-2:])
        r, events = coach_with_viewer(["--speed", "64", "--replay", record, "--report", os.path.join(tmp, "replay.html")])
        again = [l for l in r.stdout.splitlines() if l.startswith("repetitions")]
        check(r.returncode == 0 and again == summary, "coach: a replay of the recording reports %s" % again)
        check_counters(r.stdout, events, "replay")
    else:
        check(False, "coach: no recording at " + record)
    check(len(done) == 10, f"synthetic: {len(done)} repetitions counted (10), {len(rows) - len(done)} partial")
    if len(done) == 10:
        tempos = [float(r["tempo"]) for r in done]
        errors = [abs(t / f - 1) for t, f in zip(tempos, factors)]
        check(max(errors) <= 0.05, "synthetic: tempo within 5 %% of each factor (largest error %.1f %%: %s vs %s)"
              % (100 * max(errors), ["%.3f" % t for t in tempos], factors))
        bent = done[turned]
        check(float(bent["score"]) <= 50 and bent["part_to_fix"] == "left_leg" and "knee" in bent["cue"],
              f"synthetic: the turned repetition scores {bent['score']} (<= 50), part to fix {bent['part_to_fix']}, "
              f"cue '{bent['cue']}' (the left knee)")
        others = [float(r["score"]) for k, r in enumerate(done) if k != turned]
        check(min(others) > float(bent["score"]) + 20, f"synthetic: the other repetitions score {min(others):.1f}..{max(others):.1f}")
        # Starts and ends: each repetition's student seconds (time 0 = frame 1).
        lengths = [int(round(f * n)) for f in factors]
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]) * ft
        err = max(max(abs(float(r["start_time"]) - s) for r, s in zip(done[1:], starts[1:])),
                  max(abs(float(r["end_time"]) - s) for r, s in zip(done[:-1], starts[1:])))
        check(err <= 0.05, f"synthetic: starts and ends within 0.05 s of the cuts (largest {err:.3f} s)")
        # Range of motion: numpy's angles over each repetition's frames (time t = clip frame t/ft + 1).
        angles = joint_angles(walk, walk.positions(motion))
        worst = 0.0
        for r in done:
            a, b = float(r["start_time"]), float(r["end_time"])
            frames = [f for f in range(1, len(motion)) if a - 1e-6 <= (f - 1) * ft <= b + 1e-6]
            ours = angles[frames].max(0) - angles[frames].min(0)
            kata = np.array([float(r["range_" + j]) for j in ROM_JOINTS])
            worst = max(worst, float(np.abs(ours - kata).max()))
        check(worst <= 2.0, f"rom: every repetition's eight ranges within 2 deg of numpy's (largest difference {worst:.2f})")
        teacher_angles = joint_angles(walk, walk.positions())[first:nxt]
        ours = teacher_angles.max(0) - teacher_angles.min(0)
        kata = np.array([float(done[0]["range_" + j + "_teacher"]) for j in ROM_JOINTS])
        check(np.abs(ours - kata).max() <= 2.0, "rom: the teacher's ranges within 2 deg of numpy's (%s vs %s)"
              % (np.round(kata, 1).tolist(), np.round(ours, 1).tolist()))
        bent_knee = float(bent["range_left_knee"])
        print(f"     knee range: turned repetition {bent_knee:.1f} deg, teacher {float(bent['range_left_knee_teacher']):.1f}")

    # Partial: 3 cycles, half a cycle, 1.5 s still, 2 s of a dance (05_03 on this body), 3 cycles.
    three = repeat(walk, first, n, [1.0] * 3)
    half = three[1:1 + n // 2]
    pause = np.repeat(half[-1:], int(1.5 / ft), 0)
    dance = Bvh(clip_path("05_03")).motion[100:100 + int(2.0 / ft)].copy()
    root = [walk.col(walk.names[0], c) for c in ("Xposition", "Yposition", "Zposition")]
    dance[:, root] += half[-1, root] - dance[0, root]
    motion = np.concatenate([three, half, pause, dance, three[1:]])
    student = os.path.join(tmp, "partial.bvh")
    walk.write(student, motion)
    rows = score(teacher, student, tmp)
    done = [r for r in rows if r["partial"] == "0"]
    check([r["rep"] for r in done] == ["1", "2", "3", "4", "5", "6"],
          f"partial: the complete repetitions are numbered {[r['rep'] for r in done]} (1..6)")
    abandoned = 3 * n * ft
    cut = [r for r in rows if r["partial"] == "1" and abs(float(r["start_time"]) - abandoned) < 0.1]
    check(len(cut) == 1 and cut[0]["rep"] == "4",
          f"partial: the abandoned repetition is reported partial (rep 4, starting {abandoned:.2f} s): "
          f"{[(r['rep'], r['start_time'], r['partial']) for r in rows]}")

    # Natural: every walk and run of subjects 2, 5, 7, 9 against a gait cycle of another subject.
    cases = [("02_01", "07_01"), ("02_02", "05_01"), ("02_03", "09_01"), ("05_01", "07_01"), ("07_01", "02_01"),
             ("09_01", "02_03")]
    total_truth = total_kata = 0
    for name, teacher_name in cases:
        t = Bvh(clip_path(teacher_name))
        tc = left_passes(t, t.positions())
        s = Bvh(clip_path(name))
        sc = left_passes(s, s.positions())
        truth = max(0, len(sc) - 1)
        rows = score(clip_path(teacher_name), clip_path(name), tmp,
                     ["--rep-section", f"{tc[0] * t.frame_time:.6f}", f"{tc[1] * t.frame_time:.6f}"])
        counted = sum(1 for r in rows if r["partial"] == "0")
        total_truth += truth
        total_kata += counted
        check(abs(counted - truth) <= 1, f"natural: {name} vs a cycle of {teacher_name}: {counted} counted, "
              f"{truth} gait cycles from the feet (crossings at {sc})")
    print(f"natural: {total_kata} counted, {total_truth} gait cycles from the feet over {len(cases)} clips")
    shutil.rmtree(tmp, ignore_errors=True)
    if failures:
        raise SystemExit(f"{len(failures)} check(s) failed")


main()
