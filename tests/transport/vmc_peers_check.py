#!/usr/bin/python3
"""kata's VMC output read by independent peers: liblo's own `oscdump` (Debian liblo-tools) and a
python3-liblo receiver with its own numpy forward kinematics (not kata's decoder).

1. samples/vmc/vmc_send_clip plays a CMU clip (its humanoid poses through kata_vmc_write_pose):
   oscdump shows every bundle with the protocol's addresses and types, in order (Root/Pos "root",
   Bone/Pos per bone, OK 1, T), only Unity HumanBodyBones names, unit quaternions.
2. The same, received by python3-liblo: forward kinematics of the received local rotations over
   the received local positions (Unity's frame, mirrored back) puts every GPD joint of the clip
   (the "cmu" layout's 16 joints, in metres) within 1 mm, on every frame.
3. `kata coach --vmc ... --vmc-student ...` (a short clip lesson, recorded with --record): the
   student's bundles reproduce the recorded student frames' GPD joints, the ghost's the recorded
   ghosts', within 1 mm on every frame received.

Ports: free UDP ports from the kernel. Figures printed: frames checked, the largest error."""
import os, subprocess, sys, tempfile, time, zipfile, io

import numpy as np

kata_cli, source, sender, python_dir = sys.argv[1:5]
sys.path.insert(0, python_dir)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kata  # noqa: E402  (the clip's joints only: the reference the receiver is checked against)
from vmc_peer import (VRM, PARENT, GPD_CMU, GPD_VRM, CMU_METRES, Receiver, clip_gpd,  # noqa: E402
                      free_udp_port, worst_error)

clip = os.path.join(source, "data", "cmu", "07_01.bvh")
FRAMES = 300

# 1. oscdump.
port = free_udp_port()
with tempfile.TemporaryFile(mode="w+") as log:  # a file, not a pipe: oscdump never waits on its reader
    dump = subprocess.Popen(["oscdump", "-L", str(port)], stdout=log, text=True)
    time.sleep(0.5)
    subprocess.run([sender, clip, "127.0.0.1", str(port), "cmu", "4", str(FRAMES)], check=True, timeout=60)
    time.sleep(1.0)
    dump.terminate()
    dump.wait(timeout=10)
    log.seek(0)
    out = log.read()
bundles = {}
order = []
for line in out.splitlines():
    tt, address, types, *args = line.split(" ")
    if tt not in bundles:
        bundles[tt] = []
        order.append(tt)
    bundles[tt].append((address, types, args))
assert len(order) >= FRAMES * 0.95, "oscdump saw %d bundles of %d" % (len(order), FRAMES)
assert "00000000.00000000" not in bundles, "every bundle carries a timetag"
for tt in order:
    msgs = bundles[tt]
    assert msgs[0][0] == "/VMC/Ext/Root/Pos" and msgs[0][1] == "sfffffff" and msgs[0][2][0] == '"root"', msgs[0]
    assert msgs[-2] == ("/VMC/Ext/OK", "i", ["1"]), msgs[-2]
    assert msgs[-1][0] == "/VMC/Ext/T" and msgs[-1][1] == "f", msgs[-1]
    seen = []
    for address, types, args in msgs[1:-2]:
        assert address == "/VMC/Ext/Bone/Pos" and types == "sfffffff", (address, types)
        name = args[0].strip('"')
        assert name in VRM, name
        assert name == "Hips" or PARENT[name] in seen, "%s before its parent" % name
        seen.append(name)
        q = np.array([float(v) for v in args[4:8]])
        assert abs(np.linalg.norm(q) - 1.0) < 1e-5, (name, q)
    for b in GPD_VRM:
        assert b in seen, "%s missing from a bundle" % b
print("oscdump: %d bundles, every one Root/Pos, %d+ bones, OK, T; unit quaternions" % (len(order), len(GPD_VRM)))

# 2. python3-liblo + numpy FK against the clip's GPD joints.
port = free_udp_port()
rx = Receiver(port)
subprocess.run([sender, clip, "127.0.0.1", str(port), "cmu", "4", str(FRAMES)], check=True, timeout=60)
time.sleep(1.0)
rx.close()
assert len(rx.frames) == FRAMES, "received %d of %d frames" % (len(rx.frames), FRAMES)
reference = clip_gpd(clip, 1, FRAMES)
worst = worst_error(rx.frames, reference, "vmc_send_clip")
print("python3-liblo FK: %d frames of %s, every GPD joint within %.4f mm of the clip's" %
      (FRAMES, os.path.basename(clip), worst * 1e3))

# 3. kata coach --vmc / --vmc-student against its own recording.
with tempfile.TemporaryDirectory(prefix="kata_vmc_peers_") as tmp:
    pg, ps = free_udp_port(), free_udp_port()
    ghost_rx, student_rx = Receiver(pg), Receiver(ps)
    record = os.path.join(tmp, "lesson.npz")
    r = subprocess.run([kata_cli, "coach", "--headless", "--student", clip, "--teacher",
                        os.path.join(source, "data", "cmu", "02_01.bvh"), "--speed", "2", "--report", "",
                        "--record", record, "--vmc", "127.0.0.1:%d" % pg, "--vmc-student", "127.0.0.1:%d" % ps],
                       capture_output=True, text=True, timeout=120)
    time.sleep(1.0)
    ghost_rx.close()
    student_rx.close()
    assert r.returncode == 0, r.stdout + r.stderr
    assert "vmc: " in r.stdout and " sends failed" in r.stdout, r.stdout
    with zipfile.ZipFile(record) as z:
        arrays = {n[:-4]: np.load(io.BytesIO(z.read(n))) for n in z.namelist()}
    names = [n for n in arrays["joint_names"]] if "joint_names" in arrays else None
    positions, ghosts, sources = arrays["positions"], arrays["ghosts"], arrays["ghost_sources"]
    with kata.Context() as ctx, ctx.load_clip(clip) as c, c.skeleton() as sk:
        names = list(sk.names)
    idx = [names.index(n) for n in GPD_CMU]
    frames = positions.shape[0]
    assert len(student_rx.frames) == frames, "student: %d bundles for %d frames" % (len(student_rx.frames), frames)
    student_ref = positions[:, idx, :].astype(np.float64) * CMU_METRES
    worst_student = worst_error(student_rx.frames, student_ref, "coach student")
    # The ghost of the frames that have one (in order); its GPD joints through ghost_sources.
    g_of = {int(s): g for g, s in enumerate(sources)}
    gidx = [g_of[i] for i in idx]
    has = [i for i in range(frames) if np.any(ghosts[i] != 0)]
    assert len(ghost_rx.frames) >= len(has) * 0.99 and len(has) > frames // 2, (len(ghost_rx.frames), len(has))
    ghost_ref = ghosts[has][:, gidx, :].astype(np.float64) * CMU_METRES
    worst_ghost = worst_error(ghost_rx.frames[:len(has)], ghost_ref, "coach ghost")
    print("kata coach --vmc: %d student frames within %.4f mm, %d ghost frames within %.4f mm (GPD joints)" %
          (frames, worst_student * 1e3, len(has), worst_ghost * 1e3))
