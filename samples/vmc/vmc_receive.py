#!/usr/bin/python3
"""A minimal VMC receiver (a "marionette") with python3-liblo (Debian python3-liblo): prints, for
each frame, the bones it received and where forward kinematics puts the head. Run it, then point a
VMC performer at it (kata coach --vmc 127.0.0.1:39539, samples/vmc/vmc_send_clip, a tracker).

    /usr/bin/python3 samples/vmc/vmc_receive.py [PORT] [FRAMES]

The bones' local positions and rotations are in Unity's frame (left-handed, +Y up); forward
kinematics: a joint = its parent's joint + the parent's world rotation applied to its local
position; a bone's world rotation = its parent's times its local rotation."""
import sys

import liblo
import numpy as np

PARENT = {"Spine": "Hips", "Chest": "Spine", "UpperChest": "Chest", "Neck": "UpperChest", "Head": "Neck",
          "LeftShoulder": "UpperChest", "LeftUpperArm": "LeftShoulder", "LeftLowerArm": "LeftUpperArm",
          "LeftHand": "LeftLowerArm", "RightShoulder": "UpperChest", "RightUpperArm": "RightShoulder",
          "RightLowerArm": "RightUpperArm", "RightHand": "RightLowerArm", "LeftUpperLeg": "Hips",
          "LeftLowerLeg": "LeftUpperLeg", "LeftFoot": "LeftLowerLeg", "LeftToes": "LeftFoot",
          "RightUpperLeg": "Hips", "RightLowerLeg": "RightUpperLeg", "RightFoot": "RightLowerLeg",
          "RightToes": "RightFoot"}


def rotate(q, v):
    """Vector v rotated by unit quaternion q (x, y, z, w)."""
    u, w = np.asarray(q[:3]), q[3]
    return v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def multiply(a, b):
    (ax, ay, az, aw), (bx, by, bz, bw) = a, b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def joints(bones):
    """World joint positions of every received bone (those whose parents were received too)."""
    out, world = {}, {}
    for name in ["Hips"] + list(PARENT):
        if name not in bones:
            continue
        p, q = bones[name]
        parent = PARENT.get(name)
        if parent is None:
            out[name], world[name] = np.asarray(p), np.asarray(q)
        elif parent in out:
            out[name] = out[parent] + rotate(world[parent], np.asarray(p))
            world[name] = multiply(world[parent], np.asarray(q))
    return out


def main():
    port = int(sys.argv[1]) if len(sys.argv) > 1 else 39539
    limit = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    bones, frames = {}, [0]

    def bone(path, args):
        bones[args[0]] = (args[1:4], args[4:8])

    def end_of_frame(path, args):
        frames[0] += 1
        head = joints(bones).get("Head")
        where = "head at (%.3f, %.3f, %.3f) m" % tuple(head) if head is not None else "no head"
        print("frame %d t=%.3f s: %d bones, %s" % (frames[0], args[0], len(bones), where), flush=True)

    server = liblo.Server(port)
    server.add_method("/VMC/Ext/Bone/Pos", "sfffffff", bone)
    server.add_method("/VMC/Ext/T", "f", end_of_frame)
    print("listening for VMC on UDP %d" % port, flush=True)
    while not limit or frames[0] < limit:
        server.recv(100)


if __name__ == "__main__":
    main()
