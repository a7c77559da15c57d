#!/usr/bin/python3
"""`kata serve` with [vmc]: a stream's student and ghost as VMC performers, read by an independent
peer (tests/transport/vmc_peer.py: python3-liblo and a numpy forward kinematics, not kata's
decoder).

kata send plays 300 frames of CMU 07_01 as stream 7 (scored against 02_01, with a ghost) and the
same as stream 8 into one kata serve whose config sends stream 7's ghost and student to two
receivers, every frame, and stream 8's student at rate = 30:
- stream 7's student: one bundle per frame, in order, /VMC/Ext/T the frame's capture time; the
  forward kinematics of its rotations puts every GPD joint within 1 mm of the clip's;
- stream 7's ghost: one bundle per result with a ghost (the results read from serve's publisher
  with kata.Subscriber), its T the result's capture time, its FK within 1 mm of the published
  ghost's GPD joints;
- stream 8: about 30 bundles per second of clip time, the rest counted as thinned;
- the counters (--counters) balance: sent = bundles received, no send failed;
- a [vmc] target that is not HOST:PORT is refused with the config's file, line and key.
Ports: free UDP ports from the kernel; paths: a temporary directory."""
import json, os, signal, subprocess, sys, tempfile, threading, time

import numpy as np

kata_cli, source, python_dir = sys.argv[1:4]
sys.path.insert(0, python_dir)
sys.path.insert(0, os.path.join(source, "tests", "transport"))
import kata  # noqa: E402
from vmc_peer import GPD_CMU, CMU_METRES, Receiver, clip_gpd, free_udp_port, worst_error  # noqa: E402

clip = os.path.join(source, "data", "cmu", "07_01.bvh")
teacher = os.path.join(source, "data", "cmu", "02_01.bvh")
FRAMES = 300

with tempfile.TemporaryDirectory(prefix="kata_vmc_serve_") as tmp:
    # A target that is not HOST:PORT: refused with file:line and the key.
    bad = os.path.join(tmp, "bad.toml")
    open(bad, "w").write('[ingest]\nendpoints = ["bind:ipc://%s/x"]\n[publish]\nendpoints = ["ipc://%s/y"]\n'
                         '[vmc.streams]\n"7" = { ghost = "127.0.0.1" }\n' % (tmp, tmp))
    r = subprocess.run([kata_cli, "serve", "--config", bad], capture_output=True, text=True, timeout=30)
    assert r.returncode != 0 and "%s:6: 'ghost': '127.0.0.1' is not HOST:PORT" % bad in r.stderr, r.stderr

    pg, ps, p8 = free_udp_port(), free_udp_port(), free_udp_port()
    ghost_rx, student_rx, thin_rx = Receiver(pg), Receiver(ps), Receiver(p8)
    config = os.path.join(tmp, "serve.toml")
    open(config, "w").write(
        '[ingest]\nendpoints = ["bind:ipc://%s/in"]\nkind = "pull"\n[publish]\nendpoints = ["ipc://%s/out"]\n'
        '[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s"\nfirst_frame = 1\n'
        '[vmc]\nrate = 0\n[vmc.streams]\n"7" = { ghost = "127.0.0.1:%d", student = "127.0.0.1:%d" }\n'
        '"8" = { student = "127.0.0.1:%d", rate = 30 }\n' % (tmp, tmp, source, teacher, pg, ps, p8))
    counters_file = os.path.join(tmp, "counters.json")
    serve = subprocess.Popen([kata_cli, "serve", "--config", config, "--counters", counters_file],
                             stderr=subprocess.PIPE, text=True)
    results = []
    try:
        deadline = time.time() + 30
        while not os.path.exists(os.path.join(tmp, "out")) and time.time() < deadline:
            time.sleep(0.05)
        sub = kata.Subscriber("ipc://%s/out" % tmp, stream=7)
        done = threading.Event()

        def read_results():
            while not done.is_set():
                m = sub.receive(timeout=0.1)
                if m is not None:
                    results.append((m.capture_time, m.ghost))
        reader = threading.Thread(target=read_results)
        reader.start()
        time.sleep(0.5)  # the subscription reaches the publisher
        senders = [subprocess.Popen([kata_cli, "send", "--bvh", clip, "--endpoint", "ipc://%s/in" % tmp,
                                     "--stream-id", str(sid), "--layout", "cmu", "--speed", "2", "--first-frame", "1",
                                     "--frames", str(FRAMES)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    text=True) for sid in (7, 8)]
        for s in senders:
            _, err = s.communicate(timeout=60)
            assert s.returncode == 0, err
        time.sleep(1.0)
        done.set()
        reader.join()
        sub.close()
    finally:
        serve.send_signal(signal.SIGINT)
        _, err = serve.communicate(timeout=60)
    for rx in (ghost_rx, student_rx, thin_rx):
        rx.close()
    assert serve.returncode == 0, err
    counters = json.load(open(counters_file))

# Stream 7's student: every frame, in order, at its capture time, FK on the clip's GPD joints.
assert counters["streams"]["7"]["frames_in"] == FRAMES, counters["streams"]["7"]
assert len(student_rx.frames) == FRAMES, "student: %d bundles for %d frames" % (len(student_rx.frames), FRAMES)
times = [t for t, _, _ in student_rx.frames]
assert all(b > a for a, b in zip(times, times[1:])), "student bundles out of order"
worst_student = worst_error(student_rx.frames, clip_gpd(clip, 1, FRAMES), "serve student")

# Stream 7's ghost: one bundle per published result with a ghost, same time, FK on its GPD joints.
ghosts = [(t, g) for t, g in results if g is not None]
assert len(ghosts) > FRAMES // 2, "only %d of %d results had a ghost" % (len(ghosts), len(results))
assert len(ghost_rx.frames) == len(ghosts), "ghost: %d bundles for %d ghosts" % (len(ghost_rx.frames), len(ghosts))
for (t, _), (tb, _, _) in zip(ghosts, ghost_rx.frames):
    assert abs(np.float32(t) - tb) <= 1e-6 * max(1.0, abs(t)), (t, tb)
with kata.Context() as ctx, ctx.load_clip(clip) as c, c.skeleton() as sk, \
        ctx.load_model(os.path.join(source, "models", "default.kata")) as model, ctx.load_clip(teacher) as tc:
    names = list(sk.names)
    with ctx.open_stream(sk, layout="cmu", stencil=model.stencil) as stream:
        stream.attach_teacher(model, clip=tc, first_frame=1, ghost=True)
        sources = list(stream.ghost_joint_sources)
gidx = [sources.index(names.index(n)) for n in GPD_CMU]
ghost_ref = np.array([g[gidx].astype(np.float64) * CMU_METRES for _, g in ghosts])
worst_ghost = worst_error(ghost_rx.frames, ghost_ref, "serve ghost")

# Stream 8 at rate = 30: about 30 bundles a second of its clip time (300 frames at 120 Hz: 2.5 s).
v7, v8 = counters["vmc"]["7"], counters["vmc"]["8"]
assert 70 <= len(thin_rx.frames) <= 80, "rate = 30 over 2.5 s sent %d bundles" % len(thin_rx.frames)
assert v8["offered"] == FRAMES and v8["thinned"] == FRAMES - len(thin_rx.frames) and v8["sent"] == len(thin_rx.frames), v8
assert v7["sent"] == FRAMES + len(ghosts) and v7["send_failed"] == 0 and v7["dropped"] == 0 and v7["pose_failed"] == 0, v7
assert "kata serve: vmc stream 7: " in err, err
print("kata serve [vmc]: stream 7's student %d bundles within %.4f mm of the clip's GPD joints, its ghost %d bundles "
      "within %.4f mm of the published ghosts'; stream 8 at rate = 30: %d of %d frames sent, %d thinned" %
      (FRAMES, worst_student * 1e3, len(ghosts), worst_ghost * 1e3, len(thin_rx.frames), FRAMES, v8["thinned"]))
