"""An independent VMC receiver for the tests (python3-liblo and numpy, not kata's decoder): the VRM
bones' hierarchy, forward kinematics of received local rotations over received local positions
(Unity's frame mirrored back into kata's), a marionette that keeps each frame's bones, and the
GPD joints of a CMU clip to check them against. Shared by tests/transport/vmc_peers_check.py and
tests/runtime/vmc_serve_check.py, vmc_in_check.py and vmc_flood_check.py; `kata` (the Python bindings)
must be importable for clip_gpd."""
import socket, threading

import numpy as np
import liblo

VRM = ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
       "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg",
       "LeftFoot", "LeftToes", "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"]
PARENT = {"Spine": "Hips", "Chest": "Spine", "UpperChest": "Chest", "Neck": "UpperChest", "Head": "Neck",
          "LeftShoulder": "UpperChest", "LeftUpperArm": "LeftShoulder", "LeftLowerArm": "LeftUpperArm",
          "LeftHand": "LeftLowerArm", "RightShoulder": "UpperChest", "RightUpperArm": "RightShoulder",
          "RightLowerArm": "RightUpperArm", "RightHand": "RightLowerArm", "LeftUpperLeg": "Hips",
          "LeftLowerLeg": "LeftUpperLeg", "LeftFoot": "LeftLowerLeg", "LeftToes": "LeftFoot",
          "RightUpperLeg": "Hips", "RightLowerLeg": "RightUpperLeg", "RightFoot": "RightLowerLeg",
          "RightToes": "RightFoot"}
# The "cmu" layout's 16 GPD joints (spec order) and the VRM bone whose joint each is for a CMU clip.
GPD_CMU = ["Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
           "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
GPD_VRM = ["Hips", "UpperChest", "Neck", "Head", "LeftUpperArm", "LeftLowerArm", "LeftHand", "RightUpperArm",
           "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "RightUpperLeg",
           "RightLowerLeg", "RightFoot"]
CMU_METRES = 0.056444  # the rig's metres per CMU unit (kata/humanoid.h, kata_humanoid_desc)
MIRROR = np.array([-1.0, 1.0, 1.0])


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def liblo_bytes(message_or_bundle):
    """The bytes liblo sends for a bundle or message (caught on a plain UDP socket)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(5)
    liblo.send(liblo.Address("127.0.0.1", s.getsockname()[1], liblo.UDP), message_or_bundle)
    data = s.recv(65536)
    s.close()
    return data


def rss_kib(pid):
    for line in open("/proc/%d/status" % pid):
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def qmul(a, b):
    (ax, ay, az, aw), (bx, by, bz, bw) = a, b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def qrot(q, v):
    u, w = np.asarray(q[:3]), q[3]
    return v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def fk(bones, root):
    """World joints (kata's right-handed frame: Unity's x mirrored back) of one frame's bones."""
    rp, rq = root
    at, world = {}, {}
    for name in VRM:
        if name not in bones:
            continue
        p, q = (np.asarray(v, dtype=np.float64) for v in bones[name])
        parent = PARENT.get(name)
        if parent is None:
            at[name], world[name] = np.asarray(rp) + qrot(rq, p), qmul(rq, q)
        else:
            assert parent in at, "%s sent without its parent %s" % (name, parent)
            at[name] = at[parent] + qrot(world[parent], p)
            world[name] = qmul(world[parent], q)
    return {k: v * MIRROR for k, v in at.items()}


class Receiver:
    """A python3-liblo marionette: each frame's bones (ended by /VMC/Ext/T), kept in order."""

    def __init__(self, port):
        self.frames, self.bones, self.root = [], {}, ((0, 0, 0), (0, 0, 0, 1))
        self.server = liblo.Server(port)
        self.server.add_method("/VMC/Ext/Root/Pos", "sfffffff", self.on_root)
        self.server.add_method("/VMC/Ext/Bone/Pos", "sfffffff", self.on_bone)
        self.server.add_method("/VMC/Ext/T", "f", self.on_time)
        self.stop = False
        self.thread = threading.Thread(target=self.run)
        self.thread.start()

    def on_root(self, path, args):
        self.root = (args[1:4], args[4:8])

    def on_bone(self, path, args):
        self.bones[args[0]] = (args[1:4], args[4:8])

    def on_time(self, path, args):
        self.frames.append((args[0], dict(self.bones), self.root))
        self.bones = {}

    def run(self):
        while not self.stop:
            self.server.recv(20)

    def close(self):
        self.stop = True
        self.thread.join()
        self.server.free()


def clip_gpd(path, first, count):
    """The clip's 16 GPD joints (cmu layout) per frame, metres."""
    import kata  # here, so that checks without the bindings can use the rest
    with kata.Context() as ctx, ctx.load_clip(path) as clip:
        with clip.skeleton() as sk:
            names = list(sk.names)
        idx = [names.index(n) for n in GPD_CMU]
        return np.array([clip.positions(f).astype(np.float64)[idx] * CMU_METRES for f in range(first, first + count)])


def worst_error(frames, reference, what):
    """The largest |FK joint - reference joint| (m) over the frames; frames[i] is reference[i]."""
    worst = 0.0
    for i, (t, bones, root) in enumerate(frames):
        j = fk(bones, root)
        for g, b in enumerate(GPD_VRM):
            e = float(np.linalg.norm(j[b] - reference[i][g]))
            worst = max(worst, e)
            assert e < 1e-3, "%s frame %d: %s off by %.2f mm" % (what, i, b, e * 1e3)
    return worst
