#!/usr/bin/python3
"""VMC in, end to end: a VMC performer written with python3-liblo (not kata's encoder) plays a CMU
clip as VRM humanoid bone rotations into `kata serve` (the vmc-in plugin), scored against the same
clip as teacher; the csv-sink writes every result.

The performer's rotations are computed here with numpy, independently of kata: the clip's joints
(CMU 02_01, mirrored into Unity's left-handed frame), the VRM bones placed on them (Spine at the
CMU LowerBack pivot, Chest at Spine, UpperChest at Spine1, Neck at Neck1, ...), each bone's world
rotation the smallest one taking its T-pose direction (frame 0) to this frame's (a least-squares
fit, Kabsch, for a bone with several children), its local rotation relative to its parent's, and
its local position its joint's offset in its parent's frame, as a VMC performer sends them.

Beside it, a second vmc-in stream takes hostile traffic (truncated bundles, wrong types, unknown
bones, NaN, a time going back, oversized datagrams, then a flood of bundles as fast as one Python
thread sends them): every cause counted, the clean stream keeps every result with the same scores
as a run alone, kata serve's RSS stays bounded.

Figures (printed): the clean stream's mean score; the flood's rate. Ports: free UDP ports from
the kernel (bind to 0)."""
import os, signal, socket, subprocess, sys, tempfile, threading, time

import numpy as np
import liblo

kata_cli, source, python_dir, plugin_dir, vmc_send_clip = sys.argv[1:6]
sys.path.insert(0, python_dir)
import kata  # noqa: E402  (the clip's joint positions only)
sys.path.insert(0, os.path.join(source, "tests", "transport"))
from vmc_peer import free_udp_port, liblo_bytes, rss_kib  # noqa: E402

CMU_TO_METRES = 0.056444  # the CMU BVH's units (inches / 0.45 ...: cgspeed's conversion)
VRM = ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
       "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg",
       "LeftFoot", "LeftToes", "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"]
PARENT = {"Hips": None, "Spine": "Hips", "Chest": "Spine", "UpperChest": "Chest", "Neck": "UpperChest",
          "Head": "Neck", "LeftShoulder": "UpperChest", "LeftUpperArm": "LeftShoulder",
          "LeftLowerArm": "LeftUpperArm", "LeftHand": "LeftLowerArm", "RightShoulder": "UpperChest",
          "RightUpperArm": "RightShoulder", "RightLowerArm": "RightUpperArm", "RightHand": "RightLowerArm",
          "LeftUpperLeg": "Hips", "LeftLowerLeg": "LeftUpperLeg", "LeftFoot": "LeftLowerLeg", "LeftToes": "LeftFoot",
          "RightUpperLeg": "Hips", "RightLowerLeg": "RightUpperLeg", "RightFoot": "RightLowerLeg",
          "RightToes": "RightFoot"}
ON_CMU = {"Hips": "Hips", "Spine": "LowerBack", "Chest": "Spine", "UpperChest": "Spine1", "Neck": "Neck1",
          "Head": "Head", "LeftShoulder": "LeftShoulder", "LeftUpperArm": "LeftArm", "LeftLowerArm": "LeftForeArm",
          "LeftHand": "LeftHand", "RightShoulder": "RightShoulder", "RightUpperArm": "RightArm",
          "RightLowerArm": "RightForeArm", "RightHand": "RightHand", "LeftUpperLeg": "LeftUpLeg",
          "LeftLowerLeg": "LeftLeg", "LeftFoot": "LeftFoot", "LeftToes": "LeftToeBase", "RightUpperLeg": "RightUpLeg",
          "RightLowerLeg": "RightLeg", "RightFoot": "RightFoot", "RightToes": "RightToeBase"}
CHILDREN = {b: [c for c in VRM if PARENT[c] == b] for b in VRM}


def quat_of_matrix(m):
    """x y z w of a rotation matrix."""
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2
    y = np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2
    z = np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2
    x = np.copysign(x, m[2, 1] - m[1, 2])
    y = np.copysign(y, m[0, 2] - m[2, 0])
    z = np.copysign(z, m[1, 0] - m[0, 1])
    q = np.array([x, y, z, w])
    return q / np.linalg.norm(q)


def swing(a, b):
    """The smallest rotation (matrix) taking direction a to direction b."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if c < -0.999999:  # opposite: half a turn about any axis normal to a
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def kabsch(rest, now):
    """The rotation best taking the rest vectors (rows) to the current ones (least squares)."""
    h = rest.T @ now
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def vrm_frames(clip_path, first, count):
    """Per frame: (name, local position, local rotation x y z w) of every VRM bone, Unity's frame,
    metres; and the CMU joints used, for reference."""
    with kata.Context() as ctx, ctx.load_clip(clip_path) as clip:
        with clip.skeleton() as sk:
            names = list(sk.names)
        idx = [names.index(ON_CMU[b]) for b in VRM]
        mirror = np.array([-1.0, 1.0, 1.0])
        def joints(f):
            return clip.positions(f).astype(np.float64)[idx] * CMU_TO_METRES * mirror
        rest = joints(0)  # the CMU clip's frame 0: its T-pose (zero rotations)
        out = []
        for f in range(first, first + count):
            p = joints(f)
            world = {}
            bones = []
            for i, b in enumerate(VRM):
                kids = [VRM.index(c) for c in CHILDREN[b]
                        if np.linalg.norm(rest[VRM.index(c)] - rest[i]) > 1e-6]
                parent = PARENT[b]
                wp = world[parent] if parent else np.eye(3)
                if not kids:
                    w = wp
                elif len(kids) == 1:
                    w = swing(rest[kids[0]] - rest[i], p[kids[0]] - p[i])
                else:
                    w = kabsch(np.array([rest[k] - rest[i] for k in kids]), np.array([p[k] - p[i] for k in kids]))
                world[b] = w
                local = wp.T @ w
                pos = p[i] if parent is None else wp.T @ (p[i] - p[VRM.index(parent)])
                bones.append((b, pos, quat_of_matrix(local)))
            out.append(bones)
        return out, clip.frame_time


def bundle(bones, t):
    msgs = [liblo.Message("/VMC/Ext/Root/Pos", "root", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)]
    for name, p, q in bones:
        msgs.append(liblo.Message("/VMC/Ext/Bone/Pos", name, *[float(v) for v in p], *[float(v) for v in q]))
    msgs.append(liblo.Message("/VMC/Ext/OK", 1))
    msgs.append(liblo.Message("/VMC/Ext/T", float(t)))
    return liblo.Bundle(*msgs)


def run(frames, frame_time, hostile, kata_sender=False):
    """kata serve with one clean vmc-in stream (7) and, with hostile, a second one (8) under attack.
    Returns (scores of stream 7 by sequence, serve's stderr, RSS growth KiB under the flood, flood rate)."""
    with tempfile.TemporaryDirectory(prefix="kata_vmc_in_") as tmp:
        clean, attacked = free_udp_port(), free_udp_port()
        config = os.path.join(tmp, "serve.toml")
        text = ('[ingest]\nendpoints = ["bind:ipc://%s/in"]\n[publish]\nendpoints = ["ipc://%s/out"]\n'
                '[scoring]\nmodel = "%s/models/default.kata"\nteacher = "%s/data/cmu/02_01.bvh"\n'
                '[[plugins]]\npath = "%s/vmc-in.so"\nconfig = "port=%d;stream=7"\n'
                '[[plugins]]\npath = "%s/csv-sink.so"\nconfig = "path=%s/scores.csv"\n'
                % (tmp, tmp, source, source, plugin_dir, clean, plugin_dir, tmp))
        if hostile:
            text += '[[plugins]]\npath = "%s/vmc-in.so"\nconfig = "port=%d;stream=8;max_packet=4096"\n' % (
                plugin_dir, attacked)
        open(config, "w").write(text)
        serve = subprocess.Popen([kata_cli, "serve", "--config", config], stderr=subprocess.PIPE, text=True)
        growth, rate = 0, 0.0
        try:
            deadline = time.time() + 30
            while not os.path.exists(os.path.join(tmp, "out")) and time.time() < deadline:
                time.sleep(0.05)
            time.sleep(0.3)
            target = liblo.Address("127.0.0.1", clean, liblo.UDP)
            attack = None
            if hostile:
                attack = threading.Thread(target=hostile_traffic, args=(attacked, serve.pid, frames[0]))
                attack.result = None
                attack.start()
            start = time.monotonic()
            if kata_sender:  # kata's own VMC out: samples/vmc/vmc_send_clip, the clip's humanoid poses
                subprocess.run([vmc_send_clip, os.path.join(source, "data", "cmu", "02_01.bvh"), "127.0.0.1",
                                str(clean), "cmu", "1", str(len(frames))], check=True, timeout=60)
                frames = []
            for i, bones in enumerate(frames):
                due = start + i * frame_time
                while time.monotonic() < due:
                    time.sleep(max(0.0, min(0.002, due - time.monotonic())))
                liblo.send(target, bundle(bones, i * frame_time))
            if attack:
                attack.join(timeout=120)
                growth, rate = attack.result
            time.sleep(1.0)
        finally:
            serve.send_signal(signal.SIGINT)
            _, err = serve.communicate(timeout=60)
        assert serve.returncode == 0, err
        rows = [r.split(",") for r in open(os.path.join(tmp, "scores.csv")).read().splitlines()]
        head = rows[0]
        col = {k: i for i, k in enumerate(head)}
        scores = {}
        for r in rows[1:]:
            if r[col["stream_id"]] == "7":
                scores[int(r[col["frame_sequence"]])] = (float(r[col["score"]]), r[col["scored"]] == "1")
        return scores, err, growth, rate


def hostile_traffic(port, serve_pid, some_bones):
    """Every kind of bad datagram, then a flood; returns (RSS growth KiB, datagrams per second)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    to = ("127.0.0.1", port)
    good = liblo_bytes(bundle(some_bones, 1.0))
    bad = []
    bad += [good[:n] for n in range(1, len(good), 7)]  # truncated at every 7th byte
    bad.append(liblo_bytes(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", 1, 2, 3, 4, 5, 6, 7))))
    bad.append(liblo_bytes(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", 1.0))))
    bad.append(liblo_bytes(liblo.Bundle(*[liblo.Message("/VMC/Ext/Bone/Pos", "Tail%d" % i, *([0.0] * 6), 1.0)
                                       for i in range(50)])))
    bad.append(liblo_bytes(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", float("nan"), 0.0, 0.0, 0.0, 0.0,
                                                   0.0, 1.0))))
    bad.append(liblo_bytes(bundle(some_bones, 0.5)))  # a time going back
    bad.append(b"\0" * 5000)                          # oversized for max_packet=4096
    bad.append(b"not osc at all!!")
    for b in bad:
        s.sendto(b, to)
    rss0 = rss_kib(serve_pid)
    # The flood: bundles with increasing times (frames over max_rate are counted, not pushed),
    # interleaved with malformed ones, as fast as this thread sends, for 2 s.
    floods = [liblo_bytes(bundle(some_bones, 2.0 + k * 1e-3)) for k in range(200)]
    sent, t0 = 0, time.monotonic()
    while time.monotonic() - t0 < 2.0:
        for b in floods:
            s.sendto(b, to)
            s.sendto(b[:-3], to)
        sent += 2 * len(floods)
    rate = sent / (time.monotonic() - t0)
    time.sleep(0.5)
    growth = rss_kib(serve_pid) - rss0
    threading.current_thread().result = (growth, rate)


def counters(err, stream):
    for line in err.splitlines():
        if line.startswith("vmc-in: stream %d " % stream):
            body = line.split(": ", 2)[2]
            return {k: int(v) for k, v in (item.split() for item in body.split(", "))}
    raise AssertionError("no vmc-in line for stream %d in:\n%s" % (stream, err))


clip = os.path.join(source, "data", "cmu", "02_01.bvh")
N = 240  # two seconds of the clip at 120 Hz, from frame 1 (frame 0 is the T-pose)
frames, dt = vrm_frames(clip, 1, N)

alone, err_alone, _, _ = run(frames, dt, hostile=False)
c7 = counters(err_alone, 7)
assert c7["packets"] == N and c7["frames"] == N and c7["pushed"] == N, c7
assert all(c7[k] == 0 for k in ("malformed", "oversized", "wrong_type", "unknown_bone", "bad_value",
                                "out_of_order", "over_rate", "push_refused")), c7
assert sorted(alone) == list(range(N)), "every frame a result: %d of %d" % (len(alone), N)
scored = [s for s, ok in alone.values() if ok]
mean = sum(scored) / len(scored)
assert len(scored) >= N - 20, "scored after calibration: %d" % len(scored)
assert mean >= 95.0, "mean score %.2f against the same clip" % mean
print("vmc in: %d frames, %d scored, mean score %.2f against the clip it came from" % (N, len(scored), mean))

# Round trip: kata's VMC out (the humanoid rig's rotations, kata_vmc_write_pose) into kata's VMC in
# scores the clip as the python3-liblo performer's rotations do.
trip, err_trip, _, _ = run(frames, dt, hostile=False, kata_sender=True)
assert sorted(trip) == list(range(N)), "round trip: %d of %d results" % (len(trip), N)
diff = max(abs(trip[k][0] - alone[k][0]) for k in trip)
trip_mean = sum(s for s, ok in trip.values() if ok) / max(1, sum(ok for _, ok in trip.values()))
assert diff < 0.5 and trip_mean >= 95.0, (diff, trip_mean)
print("round trip kata VMC out -> kata VMC in: %d frames, mean score %.2f, largest per-frame difference from the "
      "python3-liblo performer's %.3f" % (N, trip_mean, diff))

beside, err, growth, rate = run(frames, dt, hostile=True)
c7, c8 = counters(err, 7), counters(err, 8)
assert c7["frames"] == N and c7["pushed"] == N, c7
assert sorted(beside) == list(range(N)), "the clean stream lost results under the flood: %d of %d" % (len(beside), N)
# The same frames give the same scores (alignment, calibration and all) with the attack beside.
assert all(abs(beside[k][0] - alone[k][0]) < 1e-3 for k in beside), "scores changed beside the flood"
for cause in ("malformed", "oversized", "wrong_type", "unknown_bone", "bad_value", "out_of_order", "over_rate"):
    assert c8[cause] > 0, (cause, c8)
assert c8["unknown_bone"] >= 50 and c8["oversized"] >= 1, c8
assert growth < 64 * 1024, "serve grew %d KiB under the flood" % growth
print("vmc in beside a flood of %.0f datagrams/s: stream 7 kept %d of %d results, same scores; stream 8 counted %s; "
      "RSS +%d KiB" % (rate, len(beside), N, c8, growth))
