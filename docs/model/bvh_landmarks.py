#!/usr/bin/python3
"""MediaPipe world landmarks (33 x 3, metres, camera axes: y down, z away; origin at the hips'
midpoint) made from a CMU BVH clip, as tests/api/test_anybody.cpp's converter makes them: the
landmarks on the CMU joints, face and hand points offset by fixed vectors, heels under the ankles.
Every frame of the clip, frame 0 included (so `kata score --first-frame 1` skips the T-pose on
both sides).

    /usr/bin/python3 docs/model/bvh_landmarks.py IN.bvh OUT.npy
"""
import sys
import numpy as np

METRES_PER_UNIT = 0.056444  # CMU BVH units (1/0.45 inch) to metres


def _rot(axis, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    if axis == "X":
        return np.array([[np.ones_like(c), 0 * c, 0 * c], [0 * c, c, -s], [0 * c, s, c]]).transpose(2, 0, 1)
    if axis == "Y":
        return np.array([[c, 0 * c, s], [0 * c, np.ones_like(c), 0 * c], [-s, 0 * c, c]]).transpose(2, 0, 1)
    return np.array([[c, -s, 0 * c], [s, c, 0 * c], [0 * c, 0 * c, np.ones_like(c)]]).transpose(2, 0, 1)


def positions(path):
    """World positions of every named joint, {name: (frames, 3)} in file units, and the frame time."""
    lines = open(path).read().splitlines()
    joints, stack, i, col = [], [], 0, 0
    while not lines[i].strip().startswith("MOTION"):
        t = lines[i].split()
        if t and t[0] in ("ROOT", "JOINT"):
            joints.append({"name": t[1], "parent": stack[-1] if stack else -1})
        elif t and t[0] == "End":
            joints.append({"name": None, "parent": stack[-1]})
        elif t and t[0] == "{":
            stack.append(len(joints) - 1)
        elif t and t[0] == "}":
            stack.pop()
        elif t and t[0] == "OFFSET":
            joints[stack[-1]]["offset"] = np.array([float(v) for v in t[1:4]])
        elif t and t[0] == "CHANNELS":
            joints[stack[-1]]["channels"] = (col, t[2:2 + int(t[1])])
            col += int(t[1])
        i += 1
    frame_time = float(lines[i + 2].split(":")[1])
    data = np.array([[float(v) for v in l.split()] for l in lines[i + 3:] if l.strip()])
    n = len(data)
    rot = [None] * len(joints)
    pos = [None] * len(joints)
    for k, j in enumerate(joints):
        r = np.tile(np.eye(3), (n, 1, 1))
        p = np.tile(j["offset"], (n, 1))
        c0, chans = j.get("channels", (0, []))
        for m, ch in enumerate(chans):
            v = data[:, c0 + m]
            if ch.endswith("position"):
                p = p + np.outer(v, np.eye(3)["XYZ".index(ch[0])])
            else:
                r = r @ _rot(ch[0], v)
        if j["parent"] >= 0:
            pr, pp = rot[j["parent"]], pos[j["parent"]]
            pos[k] = pp + np.einsum("nij,nj->ni", pr, p)
            rot[k] = pr @ r
        else:
            pos[k], rot[k] = p, r
    return {j["name"]: pos[k] for k, j in enumerate(joints) if j["name"]}, frame_time


def mediapipe(path):
    w, frame_time = positions(path)
    at = {k: METRES_PER_UNIT * v for k, v in w.items()}
    n = len(at["Hips"])
    ankle = min(at["LeftFoot"][1:, 1].min(), at["RightFoot"][1:, 1].min())  # frames 1.. as the test's
    l = np.zeros((n, 33, 3))
    face = [(0, 0.02, 0.10), (0.02, 0.05, 0.09), (0.03, 0.05, 0.09), (0.04, 0.05, 0.08), (-0.02, 0.05, 0.09),
            (-0.03, 0.05, 0.09), (-0.04, 0.05, 0.08), (0.07, 0, 0), (-0.07, 0, 0), (0.02, -0.02, 0.09), (-0.02, -0.02, 0.09)]
    for i, f in enumerate(face):
        l[:, i] = at["Head"] + np.array(f)
    for i, name in zip(range(11, 17), ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LeftHand", "RightHand"]):
        l[:, i] = at[name]
    l[:, 17] = l[:, 15] + (0.06, -0.02, -0.02)
    l[:, 18] = l[:, 16] + (-0.06, -0.02, -0.02)
    l[:, 19] = l[:, 15] + (0.08, 0, 0)
    l[:, 20] = l[:, 16] + (-0.08, 0, 0)
    l[:, 21] = l[:, 15] + (0.03, 0, 0.03)
    l[:, 22] = l[:, 16] + (-0.03, 0, 0.03)
    for i, name in zip(range(23, 29), ["LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg", "LeftFoot", "RightFoot"]):
        l[:, i] = at[name]
    l[:, 29] = l[:, 27] + (0, -ankle, -0.05)
    l[:, 30] = l[:, 28] + (0, -ankle, -0.05)
    l[:, 31] = at["LeftToeBase"]
    l[:, 32] = at["RightToeBase"]
    l = l - 0.5 * (l[:, 23:24] + l[:, 24:25])
    l[:, :, 1:] *= -1.0
    return l.astype(np.float32), frame_time


if __name__ == "__main__":
    arr, ft = mediapipe(sys.argv[1])
    np.save(sys.argv[2], arr)
    print("%s: %d frames, %.6f s" % (sys.argv[2], len(arr), ft))
