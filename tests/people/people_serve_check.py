#!/usr/bin/python3
"""kata serve fed people frames over ipc (a PUSH socket, kata.write_people_frame): a good group of
two people, and a bad group whose frames hold more people than its table (8), a NaN pose and an
empty frame. The stop line and --counters' "people" give each count as sent; the good group's
two persons have every frame of theirs queued on their own stream.

Usage: people_serve_check.py KATA SOURCE_DIR (KATA_LIBRARY names libkata)"""
import json, os, signal, subprocess, sys, tempfile, time

import numpy as np
import zmq

kata_cli, source = sys.argv[1:3]
sys.path.insert(0, os.path.join(source, "bindings", "python"))
import kata  # noqa: E402

N = 33  # the groups are MediaPipe skeletons
GOOD, BAD = 41, 42
FRAMES = 30


def person(i, k):
    """Person i at frame k: a 1.7 m figure standing 3 m from person i - 1, swaying."""
    h = np.linspace(0.0, 1.7, N)
    x = 3.0 * i + 0.01 * k + 0.1 * np.sin(np.arange(N) + 0.2 * k)
    return np.stack([x, h, np.zeros(N)], axis=1).astype(np.float32)


nan_pose = person(0, 2)
nan_pose[5, 1] = np.nan
bad_frames = [np.stack([person(i, 0) for i in range(2)]),
              np.stack([person(i, 1) for i in range(10)]),  # 6 new people fill the 8, 2 more are refused
              np.stack([person(i, 2) for i in range(8)] + [nan_pose]),
              np.zeros((0, N, 3), np.float32)]
bad_sent = sum(len(p) for p in bad_frames)  # 21 poses, 3 refused

with tempfile.TemporaryDirectory(prefix="kata_people_serve_") as tmp, kata.Context() as ctx, \
        ctx.create_layout("mediapipe") as mp:
    config = os.path.join(tmp, "serve.toml")
    open(config, "w").write('[ingest]\nendpoints = ["bind:ipc://%s/in"]\nkind = "pull"\nmax_frame_age_ms = 0\n'
                            '[publish]\nendpoints = ["ipc://%s/out"]\n' % (tmp, tmp))
    counters = os.path.join(tmp, "counters.json")
    serve = subprocess.Popen([kata_cli, "serve", "--config", config, "--counters", counters], stderr=subprocess.PIPE,
                             text=True)
    try:
        deadline = time.time() + 20
        while not os.path.exists(os.path.join(tmp, "in")) and time.time() < deadline:
            time.sleep(0.05)
        zc = zmq.Context()
        push = zc.socket(zmq.PUSH)
        push.setsockopt(zmq.LINGER, 5000)
        push.connect("ipc://%s/in" % tmp)
        push.send(kata.write_skeleton(GOOD, mp, layout="mediapipe"))
        push.send(kata.write_skeleton(BAD, mp, layout="mediapipe"))
        t0 = time.monotonic()
        for k in range(FRAMES):
            t = t0 + k / 30.0
            push.send(kata.write_people_frame(GOOD, k, t, np.stack([person(1, k), person(0, k)][::1 - 2 * (k % 2)])))
            if k < len(bad_frames):
                push.send(kata.write_people_frame(BAD, k, t, bad_frames[k]))
        push.close()
        zc.term()
        time.sleep(1.0)
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=60)
    assert serve.returncode == 0, err
    line = [l for l in err.splitlines() if l.startswith("kata serve: people frames")]
    assert len(line) == 1, err
    tracked_frames = FRAMES + len(bad_frames)
    expected = ("kata serve: people frames %d tracked (1 empty) + 0 refused; poses %d = %d tracked + 3 refused "
                "(non-finite 1, out of range 0, too few joints 0, too many poses 0, table full 2); person streams "
                "10 opened, 0 closed, 0 refused (0 poses dropped)"
                % (tracked_frames, 2 * FRAMES + bad_sent, 2 * FRAMES + bad_sent - 3))
    assert line[0] == expected, "\n%s\n%s" % (line[0], expected)
    data = json.load(open(counters))
    people = data["people"]
    assert people["frames"] == tracked_frames and people["empty_frames"] == 1 and people["refused_frames"] == 0, people
    assert people["poses"] == 2 * FRAMES + bad_sent and people["poses_tracked"] == 2 * FRAMES + bad_sent - 3, people
    assert people["refused_table_full"] == 2 and people["refused_non_finite"] == 1, people
    assert people["streams_opened"] == 10 and people["poses_unopened"] == 0, people
    assert data["ingest"]["frames"] == tracked_frames and data["ingest"]["dropped"] == 0, data["ingest"]
    # The good group's two persons: every one of their poses a frame of their own stream.
    for k in (1, 2):
        s = data["streams"][str(kata.people_stream_id(GOOD, k))]
        assert s["frames_in"] == FRAMES, (k, s)
    # Every tracked pose was a frame of its person's stream, and every one a result published.
    assert "stopped; %d frames in, %d results published" % ((2 * FRAMES + bad_sent - 3,) * 2) in err, err
print("people serve ok")
