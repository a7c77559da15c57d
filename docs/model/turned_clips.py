"""The clips the balance-table scripts score (coaching_frontier.py, landmark_balance.py,
landmark_torso.py): 3 s excerpts of CMU clips (frame 0, the T-pose, and the 360 frames after it)
and their copies with one joint turned by a fixed angle on every frame (the `bend-joint` tool,
looked for in `tools/bend-joint` two folders above the clips' folder: ../shared/tools)."""
import os
import subprocess

EXCERPT_FRAMES = 361  # frame 0 and 3 s at 120 Hz


def bend_tool(data):
    """The bend-joint tool for the clips' folder `data`."""
    return os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(data))), "tools", "bend-joint")


def excerpt(data, work, clip):
    """work/CLIP.bvh: the first EXCERPT_FRAMES frames of data/CLIP.bvh (made once)."""
    out = os.path.join(work, clip + ".bvh")
    if not os.path.exists(out):
        lines = open(os.path.join(data, clip + ".bvh")).read().splitlines()
        i = next(k for k, l in enumerate(lines) if l.strip().startswith("MOTION"))
        body = [l for l in lines[i + 3:] if l.strip()][:EXCERPT_FRAMES]
        lines[i + 1] = "Frames: %d" % len(body)
        open(out, "w").write("\n".join(lines[:i + 3] + body) + "\n")
    return out


def turned(data, work, clip, joint, degrees, axis, quiet=False):
    """work/CLIP_JOINT_DEGREES.bvh: the excerpt with `joint` turned by `degrees` about its local
    `axis` (X, Y or Z) on every frame (made once)."""
    out = os.path.join(work, "%s_%s_%d.bvh" % (clip, joint, degrees))
    if not os.path.exists(out):
        subprocess.run([bend_tool(data), excerpt(data, work, clip), out, joint, str(degrees), axis], check=True,
                       stdout=subprocess.DEVNULL if quiet else None)
    return out
