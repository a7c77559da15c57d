#!/usr/bin/python3
"""kata serve's practice settings: [scoring] loop = [A, B] and a per-stream
[scoring.practice] teacher_start. A clip sent as two streams against the teacher 07_01 (frames from 1):
stream 1 loops clip frames 100..220 (every matched teacher row in 99..219), stream 2 starts at clip
frame 200 (no row before 199). A section outside the clip, or both settings in one table, is refused
with file:line. Then the same set by the senders' own practice messages (kata send --loop /
--teacher-start, teacher seconds), one beyond the clip refused and counted by the server. Unique
paths per run; every wait bounded."""
import csv, os, signal, subprocess, sys, tempfile, time

kata, source, plugin_dir = sys.argv[1:4]
teacher = os.path.join(source, "data", "cmu", "07_01.bvh")
with tempfile.TemporaryDirectory(prefix="kata_serve_practice_") as tmp:
    def serve_config(name, scoring_extra, practice=""):
        path = os.path.join(tmp, name)
        open(path, "w").write(
            '[ingest]\nendpoints = ["bind:ipc://%s/in"]\nkind = "pull"\n[publish]\nendpoints = ["ipc://%s/out"]\n'
            '[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s"\nghost = false\n%s%s'
            '[[plugins]]\npath = "%s/csv-sink.so"\nconfig = "path=%s/scores.csv"\n'
            % (tmp, tmp, source, teacher, scoring_extra, practice, plugin_dir, tmp))
        return path

    # Refusals, at start, naming the line of the setting (line 8: the first after ghost).
    for extra, practice, message in [
            ("loop = [100, 5000]\n", "", "practice frame 5000 is outside"),
            ("loop = [220, 100]\n", "", "needs 0 <= A <= B"),
            ("teacher_start = 10\nloop = [100, 220]\n", "", "not both"),
            ("", '[scoring.practice]\n"2" = { teacher_start = 0 }\n', "practice frame 0 is outside")]:
        bad = serve_config("bad.toml", extra, practice)
        r = subprocess.run([kata, "serve", "--config", bad], capture_output=True, text=True, timeout=60)
        assert r.returncode == 1 and message in r.stderr and (bad + ":") in r.stderr, (extra, practice, r.stderr)

    config = serve_config("serve.toml", "loop = [100, 220]\n", '[scoring.practice]\n"2" = { teacher_start = 200 }\n')
    serve = subprocess.Popen([kata, "serve", "--config", config], stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 30
        while not os.path.exists(os.path.join(tmp, "out")) and time.time() < deadline:
            time.sleep(0.05)
        subprocess.run([kata, "send", "--bvh", teacher, "--endpoint", "ipc://%s/in" % tmp, "--stream-id", "1",
                        "--streams", "2", "--speed", "4"], check=True, timeout=120)
        time.sleep(1.0)
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=60)
    assert serve.returncode == 0, err
    rows = list(csv.DictReader(open(os.path.join(tmp, "scores.csv"))))
    frames = 316  # 07_01 has 317 frames; kata send plays 1..316
    for stream, lo, hi in [("1", 99, 219), ("2", 199, frames - 1)]:
        matched = [int(r["matched_teacher_frame"]) for r in rows if r["stream_id"] == stream and r["scored"] == "1"]
        assert len(matched) == frames, (stream, len(matched))
        assert min(matched) >= lo and max(matched) <= hi, (stream, min(matched), max(matched))
        print("stream %s: %d scored, matched teacher rows %d..%d (section %d..%d)" % (
            stream, len(matched), min(matched), max(matched), lo, hi))

    # The same from the senders' own practice messages (kata send --loop / --teacher-start, teacher
    # seconds: 07_01 is at 120 Hz, so 1.0..2.0 s is rows 120..240), on a serve with no practice of
    # its own; a start beyond the clip (2.6 s) is refused by the server, counted, and that stream
    # keeps the whole clip; a loop that cannot be is refused by kata send before it sends anything.
    config = serve_config("plain.toml", "")
    serve = subprocess.Popen([kata, "serve", "--config", config], stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 30
        while not os.path.exists(os.path.join(tmp, "out")) and time.time() < deadline:
            time.sleep(0.05)
        send = [kata, "send", "--bvh", teacher, "--endpoint", "ipc://%s/in" % tmp, "--speed", "4"]
        bad = subprocess.run(send + ["--stream-id", "9", "--loop", "2", "1"], capture_output=True, text=True, timeout=60)
        assert bad.returncode == 1 and "loop_end 1 s is not after loop_start 2 s" in bad.stderr, bad.stderr
        for stream, practice in [("3", ["--loop", "1.0", "2.0"]), ("4", ["--teacher-start", "2.0"]),
                                 ("5", ["--teacher-start", "100"])]:
            subprocess.run(send + ["--stream-id", stream] + practice, check=True, timeout=120)
        time.sleep(1.0)
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=60)
    assert serve.returncode == 0, err
    assert "sends a practice setting outside the teacher clip (stream 5: 100 s is outside the teacher clip" in err, err
    assert "+ 2 practice settings + " in err and "practice outside the clip 1," in err, err
    rows = list(csv.DictReader(open(os.path.join(tmp, "scores.csv"))))
    for stream, lo, hi in [("3", 120, 240), ("4", 240, frames - 1), ("5", 0, frames - 1)]:
        matched = [int(r["matched_teacher_frame"]) for r in rows if r["stream_id"] == stream and r["scored"] == "1"]
        assert len(matched) == frames, (stream, len(matched))
        assert min(matched) >= lo and max(matched) <= hi, (stream, min(matched), max(matched))
        print("stream %s (kata send): %d scored, matched teacher rows %d..%d (section %d..%d)" % (
            stream, len(matched), min(matched), max(matched), lo, hi))
    assert max(int(r["matched_teacher_frame"]) for r in rows if r["stream_id"] == "5") > 240, "the whole clip"
print("serve practice ok")
