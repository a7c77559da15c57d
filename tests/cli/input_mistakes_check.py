#!/usr/bin/python3
"""The CLI's side of the newcomer's mistakes, each made here and named by its message:
- a .npy student without --layout: the message names the student file and the flags that give it
  (--layout, --student-layout), and no message names --preset;
- MediaPipe landmarks in pixels given to kata score: refused naming the body size and pixels;
- kata score's "most to fix" is the part its per-frame part_to_fix names most often (recomputed
  here from the CSV);
- kata send --layout cmuu to a running kata serve with --results: the server's refusal comes back
  on the stream's results topic, kata send names it and fails; a good layout ends with exit 0.
Unique ipc paths per run; every wait bounded; no timing asserted."""
import collections
import csv
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

kata, source = sys.argv[1:3]
cmu = os.path.join(source, "data", "cmu")


def run(*args):
    return subprocess.run([kata] + list(args), capture_output=True, text=True, timeout=120)


with tempfile.TemporaryDirectory(prefix="kata_mistakes_") as tmp:
    # A standing MediaPipe body in metres (y down): nose 0.75 m above the hips, ankles 0.8 m below.
    n = 60
    lm = np.zeros((n, 33, 3), np.float32)
    lm[:, :11] = [0.0, -0.75, 0.05]
    lm[:, 11:23] = [[0.18 * (1 if i % 2 else -1), -0.5 + 0.03 * i, 0.0] for i in range(12)]
    lm[:, 23:33] = [[0.1 * (1 if i % 2 else -1), 0.1 * i, 0.0] for i in range(10)]
    lm[:, 27:29, 1] = 0.8
    lm[:, :, 0] += 0.01 * np.sin(np.arange(n) / 5.0)[:, None]  # a little motion
    times = np.arange(n) * 1000.0 / 30
    student = os.path.join(tmp, "student.npy")
    np.save(student, lm)
    np.save(os.path.join(tmp, "student.times.npy"), times)

    # 1. A .npy student without --layout: the student named, the current flags, no --preset.
    r = run("score", "--model", "models/default.kata", "--teacher", os.path.join(cmu, "02_01.bvh"),
            "--student", student, "--out", os.path.join(tmp, "x.csv"))
    assert r.returncode != 0, r.stderr
    assert student + ": a landmark array needs a layout: give --layout (both inputs) or --student-layout" in r.stderr, r.stderr
    assert "02_01.bvh" not in r.stderr and "--preset" not in r.stderr, r.stderr
    r = run("score", "--model", "models/default.kata", "--teacher", os.path.join(cmu, "02_01.bvh"),
            "--student", os.path.join(cmu, "07_01.bvh"), "--out", os.path.join(tmp, "x.csv"))
    assert r.returncode != 0 and "give a layout (--layout cmu)" in r.stderr and "--preset" not in r.stderr, r.stderr

    # 2. Pixels: x * 1920, y * 1080.
    px = lm.copy()
    px[:, :, 0] *= 1920
    px[:, :, 1] *= 1080
    pixels = os.path.join(tmp, "pixels.npy")
    np.save(pixels, px)
    np.save(os.path.join(tmp, "pixels.times.npy"), times)
    size = float(np.median(np.linalg.norm(0.5 * (px[:, 27] + px[:, 28]) - px[:, 0], axis=1)))
    r = run("score", "--model", "models/default.kata", "--teacher", os.path.join(cmu, "02_01.bvh"),
            "--teacher-layout", "cmu", "--student", pixels, "--student-layout", "mediapipe",
            "--out", os.path.join(tmp, "x.csv"))
    assert r.returncode != 0, r.stderr
    assert "%s: the body measures %.4g from the nose to the ankles" % (pixels, size) in r.stderr, r.stderr
    assert "Pixel coordinates" in r.stderr, r.stderr
    r = run("score", "--model", "models/default.kata", "--teacher", os.path.join(cmu, "02_01.bvh"),
            "--teacher-layout", "cmu", "--student", student, "--student-layout", "mediapipe",
            "--out", os.path.join(tmp, "x.csv"))
    assert "the body measures" not in r.stderr and "upside down" not in r.stderr, r.stderr

    # 3. "most to fix" is the part the part_to_fix column names most often.
    out = os.path.join(tmp, "score.csv")
    r = run("score", "--model", "models/default.kata", "--teacher", os.path.join(cmu, "02_01.bvh"),
            "--student", os.path.join(cmu, "07_01.bvh"), "--layout", "cmu", "--first-frame", "1", "--out", out)
    assert r.returncode == 0, r.stderr
    rows = [row for row in csv.DictReader(open(out)) if row["state"] == "scoring"]
    named = collections.Counter(row["part_to_fix"] for row in rows if row["part_to_fix"])
    part, count = named.most_common(1)[0]
    assert "most to fix: %s (part_to_fix on %d of %d scored frames)" % (part, count, len(rows)) in r.stdout, r.stdout

    # 4. kata send into kata serve with a layout the server does not know: the refusal comes back.
    config = os.path.join(tmp, "serve.toml")
    open(config, "w").write('[ingest]\nendpoints = ["bind:ipc://%s/in"]\nkind = "pull"\n'
                            '[publish]\nendpoints = ["ipc://%s/out"]\n' % (tmp, tmp))
    serve = subprocess.Popen([kata, "serve", "--config", config], stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 30
        while not os.path.exists(os.path.join(tmp, "in")) and time.time() < deadline:
            time.sleep(0.05)
        base = ["send", "--bvh", os.path.join(cmu, "07_01.bvh"), "--endpoint", "ipc://%s/in" % tmp, "--frames", "120",
                "--speed", "4", "--results", "ipc://%s/out" % tmp, "--connect-timeout", "10"]
        r = run(*(base + ["--layout", "cmuu", "--stream-id", "4"]))
        assert r.returncode == 1, (r.returncode, r.stderr)
        assert "send: kata serve refused stream 4: " in r.stderr and "cmuu" in r.stderr, r.stderr
        assert "its frames were dropped" in r.stderr, r.stderr
        r = run(*(base + ["--layout", "cmu", "--stream-id", "5"]))
        assert r.returncode == 0, r.stderr
        assert "refused" not in r.stderr and "no word from" not in r.stderr, r.stderr
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=30)
    assert "stream 4's skeleton definition (layout 'cmuu') refused" in err, err
print("ok")
