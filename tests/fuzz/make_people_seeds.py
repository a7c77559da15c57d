#!/usr/bin/env python3
"""Writes the seed corpus of fuzz_people (tests/fuzz/corpus/people): stick figures of 17 joints
(COCO's count) walking past each other, one hidden for a while, with confidences; a NaN pose, a
frame with more poses than max_poses, empty frames and a repeated time. Input layout:
tests/fuzz/fuzz_people.cpp. Usage: make_people_seeds.py OUT_DIR"""
import math
import os
import struct
import sys


def figure(joints, x, z, phase):
    out = []
    for j in range(joints):
        h = 1.7 * j / (joints - 1)
        out += [x + (0.2 * math.sin(phase + j) if j % 3 == 1 else 0.0), h, z]
    return out


def int16s(values):
    return b"".join(struct.pack("<h", max(-32768, min(32767, round(v * 256)))) for v in values)


def seed(joints, people, poses, flags, frames):
    data = bytes([joints - 1, people - 1, poses - 1, flags])
    for step, figures, raw in frames:
        data += bytes([step, len(figures)])
        for i, f in enumerate(figures):
            mode = 1 if (raw and i == 0) or any(v != v for v in f) else 0
            data += bytes([mode])
            data += struct.pack("<%df" % len(f), *f) if mode & 1 else int16s(f)
        if flags & 1:
            for _ in figures:
                data += bytes([200 - (k * 7) % 120 for k in range(joints)])
    return data


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    crossing = []
    for k in range(40):
        s = k / 10.0
        xa, xb = -2.0 + 0.8 * s, 2.0 - 0.8 * s
        figs = [figure(17, xa, 0.0, 3 * s)]
        if abs(xa - xb) > 0.3:
            figs.insert(k % 2, figure(17, xb, 0.0, 3 * s + 1))
        crossing.append((10, figs, False))
    seeds = {
        "crossing": seed(17, 4, 4, 1 | 2, crossing),
        "crossing_no_confidence": seed(17, 4, 4, 2, crossing[:20]),
        "nan_pose": seed(5, 2, 2, 0, [(3, [figure(5, 0, 0, 0), [float("nan")] * 15], True),
                                      (3, [figure(5, 0.1, 0, 0.1)], False)]),
        "too_many_poses": seed(5, 2, 2, 1, [(3, [figure(5, x, 0, 0) for x in range(6)], False)] * 3),
        "empty_and_repeat": seed(5, 2, 2, 0, [(3, [figure(5, 0, 0, 0)], False), (0, [], False),
                                              (0, [figure(5, 0, 0, 0)], False), (255, [], False),
                                              (200, [], False), (200, [figure(5, 0, 0, 0)], False)]),
    }
    for name, data in seeds.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
