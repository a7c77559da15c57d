#!/usr/bin/python3
"""Score a recording of 3D landmarks (an .npy of frames x joints x 3, e.g. a pose estimator's output)
against a teacher's BVH clip, frame by frame, as a live app would: every frame pushed into a stream,
results drained in bulk, per-part blame summed.

The landmarks use the CMU joint layout (31 joints in the order of a CMU BVH's HIERARCHY; the names and
parents come from --layout-bvh). They carry no bone lengths, so the stream is a bare live source: the
body height is estimated from the first frames, and no ghost is made (a ghost needs rest offsets).

  PYTHONPATH=bindings/python /usr/bin/python3 samples/python/score_landmarks.py \
      --landmarks student.npy --fps 120 --teacher data/cmu/02_01.bvh --model models/default.kata
Without --landmarks, a stand-in recording is made from data/cmu/07_01.bvh (subject 7 walking).
"""
import argparse
import os

import numpy as np

import kata

REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
PARTS = ["torso/head", "left arm", "right arm", "left leg", "right leg"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--landmarks", help=".npy, frames x joints x 3 float, CMU joint order, +Y up")
    ap.add_argument("--fps", type=float, default=120.0, help="frame rate of the landmarks")
    ap.add_argument("--layout-bvh", default=os.path.join(REPO, "data/cmu/07_01.bvh"),
                    help="a BVH whose HIERARCHY names the landmarks' joints (CMU layout)")
    ap.add_argument("--teacher", default=os.path.join(REPO, "data/cmu/02_01.bvh"))
    ap.add_argument("--model", default=os.path.join(REPO, "models/default.kata"))
    ap.add_argument("--chunk", type=int, default=32, help="frames pushed between two reads (a 120 Hz tracker read at ~4 Hz)")
    a = ap.parse_args()

    with kata.Context() as ctx, ctx.load_skeleton_bvh(a.layout_bvh) as layout:
        if a.landmarks:
            landmarks = np.load(a.landmarks).astype(np.float32)
        else:  # stand-in for a pose estimator: a recorded student without its T-pose frame
            with ctx.load_clip(os.path.join(REPO, "data/cmu/07_01.bvh")) as clip:
                landmarks = clip.all_positions(first=1)
                a.fps = 1.0 / clip.frame_time
        if landmarks.ndim != 3 or landmarks.shape[1:] != (layout.joint_count, 3):
            raise SystemExit("landmarks must be frames x %d x 3 (got %s)" % (layout.joint_count, landmarks.shape))
        # Names and parents only: a bare live source without bone lengths.
        with ctx.create_skeleton(layout.names, layout.parents) as student, ctx.load_model(a.model) as model, \
                ctx.load_clip(a.teacher) as teacher, \
                ctx.open_stream(student, preset="cmu", stencil=model.stencil, result_capacity=4 * a.chunk) as s:
            s.attach_teacher(model, clip=teacher, first_frame=1, ghost=False)
            buf = s.result_buffer(4 * a.chunk)
            times = np.arange(len(landmarks)) / a.fps
            scores, parts = [], np.zeros(5)
            for start in range(0, len(landmarks), a.chunk):
                s.push_many(times[start:start + a.chunk], landmarks[start:start + a.chunk])
                r = s.read_results(buf)
                scored = r.results["scored"] != 0
                scores.extend(r.scores["score"][scored].tolist())
                parts += r.scores["parts"][scored].sum(axis=0)
            print("%d landmark frames, %d scored (the first %d calibrate the body height: %.3g units)"
                  % (len(landmarks), len(scores), len(landmarks) - len(scores), s.body_height))
            print("mean score %.1f / 100, median %.1f; most to fix: %s" % (np.mean(scores), np.median(scores),
                                                                         PARTS[int(np.argmax(parts))]))


if __name__ == "__main__":
    main()
