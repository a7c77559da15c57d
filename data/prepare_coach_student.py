#!/usr/bin/python3
"""Prepares the default clips of `kata coach` (a reproducible step; its output is committed).

Teacher: CMU 05_18 (subject 5, dance choreography), copied byte for byte.
Student: the same choreography performed again by subject 5 (CMU 05_19), put on a different body:
  - HIERARCHY: subject 2's skeleton (02_01.bvh's, byte for byte: other bone lengths),
  - MOTION: 05_19's rows, every rotation channel copied verbatim (the same tokens),
  - root translation (the Hips X/Y/Z position channels) scaled by the leg-length ratio
    L(subject 2) / L(subject 5), L = mean over both legs of |LeftLeg OFFSET| + |LeftFoot OFFSET|
    (thigh + shin: what sets hip height and stride length), so the smaller body's hips stay at
    its own height and its steps cover proportionally less ground.

Usage: /usr/bin/python3 data/prepare_coach_student.py [--src DIR] [--out DIR] [--check]
  --src  the CMU developer set (default ../shared/data/cmu next to the repository)
  --out  where to write 05_18.bvh and 05_19_on_02.bvh (default data/cmu of the repository)
  --check  write nothing; exit 1 if the committed files differ from what this script makes.
Only the standard library is used.
"""
import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
TEACHER, MOTION, BODY = "05_18.bvh", "05_19.bvh", "02_01.bvh"
STUDENT_OUT = "05_19_on_02.bvh"


def split_bvh(text, name):
    """(hierarchy text up to and including 'MOTION\\n', frames line, frame-time line, motion rows)."""
    at = text.find("\nMOTION")
    if at < 0:
        sys.exit(f"{name}: no MOTION section")
    head_end = text.index("\n", at + 1) + 1
    rest = text[head_end:].splitlines()
    if len(rest) < 3 or not rest[0].startswith("Frames:") or not rest[1].startswith("Frame Time:"):
        sys.exit(f"{name}: MOTION section without Frames / Frame Time lines")
    rows = [r for r in rest[2:] if r.strip()]
    frames = int(rest[0].split(":")[1])
    if frames != len(rows):
        sys.exit(f"{name}: Frames: {frames} but {len(rows)} motion rows")
    return text[:head_end], rest[0], rest[1], rows


def joint_offsets(hierarchy, name):
    """{joint name: (x, y, z)} from the HIERARCHY text (End Sites skipped)."""
    offsets, current = {}, None
    for line_no, line in enumerate(hierarchy.splitlines(), 1):
        words = line.split()
        if not words:
            continue
        if words[0] in ("ROOT", "JOINT"):
            current = words[1]
        elif words[0] == "End":
            current = None
        elif words[0] == "OFFSET" and current is not None:
            try:
                offsets[current] = tuple(float(w) for w in words[1:4])
            except ValueError:
                sys.exit(f"{name}:{line_no}: OFFSET is not three numbers")
            current = None
    return offsets


def channel_layout(hierarchy):
    """Joint names in file order with their channel lists (to check both files share the layout)."""
    layout, current = [], None
    for line in hierarchy.splitlines():
        words = line.split()
        if words and words[0] in ("ROOT", "JOINT"):
            current = words[1]
        elif words and words[0] == "CHANNELS":
            layout.append((current, tuple(words[2:])))
    return layout


def leg_length(offsets, name):
    try:
        sides = [("LeftLeg", "LeftFoot"), ("RightLeg", "RightFoot")]
        return sum(math.dist((0, 0, 0), offsets[a]) + math.dist((0, 0, 0), offsets[b]) for a, b in sides) / 2
    except KeyError as e:
        sys.exit(f"{name}: no joint {e} (a CMU skeleton is expected)")


def make_student(src):
    read = lambda f: open(os.path.join(src, f), encoding="ascii").read()
    motion_head, frames_line, time_line, rows = split_bvh(read(MOTION), MOTION)
    body_head, _, _, _ = split_bvh(read(BODY), BODY)
    if channel_layout(motion_head) != channel_layout(body_head):
        sys.exit(f"{MOTION} and {BODY} do not share joints and channels")
    layout = channel_layout(body_head)
    root_channels = layout[0][1]
    position_columns = [i for i, c in enumerate(root_channels) if c.endswith("position")]
    ratio = leg_length(joint_offsets(body_head, BODY), BODY) / leg_length(joint_offsets(motion_head, MOTION), MOTION)
    out_rows = []
    for row in rows:
        values = row.split()
        for i in position_columns:
            values[i] = f"{float(values[i]) * ratio:.4f}"
        out_rows.append(" ".join(values))
    text = body_head + frames_line + "\n" + time_line + "\n" + "\n".join(out_rows) + "\n"
    return text, ratio, len(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--src", default=os.path.join(HERE, "..", "..", "shared", "data", "cmu"))
    ap.add_argument("--out", default=os.path.join(HERE, "cmu"))
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    for f in (TEACHER, MOTION, BODY):
        if not os.path.isfile(os.path.join(a.src, f)):
            sys.exit(f"{os.path.join(a.src, f)}: missing (give the CMU developer set with --src)")
    student, ratio, frames = make_student(a.src)
    teacher = open(os.path.join(a.src, TEACHER), encoding="ascii").read()
    outputs = {TEACHER: teacher, STUDENT_OUT: student}
    if a.check:
        bad = [f for f, t in outputs.items()
               if not os.path.isfile(os.path.join(a.out, f)) or open(os.path.join(a.out, f), encoding="ascii").read() != t]
        print("differs: " + ", ".join(bad) if bad else "committed clips match")
        return 1 if bad else 0
    for f, t in outputs.items():
        with open(os.path.join(a.out, f), "w", encoding="ascii", newline="\n") as out:
            out.write(t)
    print(f"{STUDENT_OUT}: {frames} frames of {MOTION} on {BODY}'s skeleton, root translation x {ratio:.5f}; "
          f"{TEACHER} copied")
    return 0


if __name__ == "__main__":
    sys.exit(main())
