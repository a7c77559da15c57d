#!/usr/bin/python3
"""Writes the seed corpus of fuzz_vmc (tests/fuzz/corpus/vmc): sequences of VMC datagrams, each a
2-byte big-endian length + the bytes python3-liblo sends (captured on a UDP socket), as
fuzz_vmc.cpp reads them.

    /usr/bin/python3 tests/fuzz/make_vmc_seeds.py tests/fuzz/corpus/vmc"""
import math, os, socket, struct, sys

import liblo

BONES = ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
         "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg",
         "LeftFoot", "LeftToes", "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"]


def captured(packet):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(5)
    liblo.send(liblo.Address("127.0.0.1", s.getsockname()[1], liblo.UDP), packet)
    data = s.recv(65536)
    s.close()
    return data


def frame(t, turn=0.0, bones=BONES, positions=True):
    msgs = [liblo.Message("/VMC/Ext/Root/Pos", "root", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)]
    for i, b in enumerate(bones):
        p = (0.0, 0.9, 0.0) if b == "Hips" else ((0.1 * (i % 3), 0.1, 0.02) if positions else (0.0, 0.0, 0.0))
        a = turn * (i + 1) * 0.1
        msgs.append(liblo.Message("/VMC/Ext/Bone/Pos", b, *p, math.sin(a), 0.0, 0.0, math.cos(a)))
    msgs.append(liblo.Message("/VMC/Ext/OK", 1))
    msgs.append(liblo.Message("/VMC/Ext/T", float(t)))
    return captured(liblo.Bundle(*msgs))


def write(directory, name, datagrams):
    with open(os.path.join(directory, name), "wb") as f:
        for d in datagrams:
            f.write(struct.pack(">H", min(len(d), 0xffff)) + d[:0xffff])


directory = sys.argv[1]
os.makedirs(directory, exist_ok=True)
write(directory, "frames", [frame(0.1 * k, 0.3 * k) for k in range(4)])
write(directory, "rotations-only", [frame(0.1 * k, 0.2 * k, positions=False) for k in range(3)])
good = frame(1.0, 0.5)
write(directory, "truncated", [good[:n] for n in (7, 16, 40, len(good) // 2, len(good) - 4)] + [frame(2.0)])
write(directory, "messages-alone", [captured(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)),
                                     captured(liblo.Message("/VMC/Ext/Bone/Pos", "LeftUpperArm", 0.1, 0.0, 0.0, 0.0, 0.0, 0.7, 0.7)),
                                     captured(liblo.Message("/VMC/Ext/T", 3.0))])
write(directory, "hostile", [
    captured(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", 1, 2, 3, 4, 5, 6, 7))),
    captured(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Tail", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))),
    captured(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", float("nan"), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))),
    captured(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))),
    captured(liblo.Bundle(liblo.Message("/VMC/Ext/Root/Pos", "root", *([1.0] * 13)))),
    captured(liblo.Bundle(liblo.Message("/VMC/Ext/Blend/Val", "Joy", 1.0))),
    frame(5.0), frame(4.5), frame(1.0),
])
# A frame inside a bundle inside a bundle (OSC allows nesting; the reader bounds its depth).
inner = frame(6.0)
outer = b"#bundle\0" + struct.pack(">II", 0, 1) + struct.pack(">I", len(inner)) + inner
write(directory, "nested", [outer, b"#bundle\0" + struct.pack(">II", 0, 1) + struct.pack(">I", len(outer)) + outer])
print("seeds in", directory)
