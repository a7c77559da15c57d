#!/usr/bin/env python3
"""Score a recording of 3D landmarks (an .npy, e.g. a pose estimator's output) against a teacher's
BVH clip, frame by frame, as a live app would: every frame pushed into a stream, results read as
they come, per-part blame summed.

The landmarks are frames x joints x 3, 4 or 5 (x, y, z[, confidence | visibility, presence]):
  - 33 joints: MediaPipe Pose world landmarks (metres, camera axes), as MediaPipe writes them
    ((frames, 33, 4) with visibility, or 5 with presence), scored through kata.mediapipe;
  - 31 joints: the CMU layout (a CMU BVH's joints in its order, +Y up, its units), the "cmu" layout.
The times are --fps, or --times (an .npy, one per frame, seconds or milliseconds: inferred), or
X.times.npy beside X.npy. Without bone lengths the stream is a bare live source: the body height
is estimated from the first frames and no ghost is made (a ghost needs rest offsets).

  python3 score_landmarks.py --landmarks student.npy --fps 30 --teacher teacher.bvh
Without --landmarks, a stand-in recording is made from data/cmu/07_01.bvh (subject 7 walking).
The teacher and the model default to the clips and model kata ships (kata.find_data), so this
runs from a checkout (PYTHONPATH=bindings/python) and from an install (share/kata/samples).
"""
import argparse
import os

import numpy as np

import kata
import kata.mediapipe

PARTS = ["torso/head", "left arm", "right arm", "left leg", "right leg"]


def times_of(a, count):
    """One timestamp per frame in seconds: --times, X.times.npy beside X.npy, else --fps."""
    path = a.times or (a.landmarks[:-len(".npy")] + ".times.npy" if a.landmarks and a.landmarks.endswith(".npy")
                       else None)
    if path and os.path.exists(path):
        t = np.load(path).astype(np.float64).reshape(-1)
        if len(t) != count:
            raise SystemExit("%s: %d times for %d frames" % (path, len(t), count))
        return t / (1000.0 if kata.detect_time_units(t) == "ms" else 1.0)
    return np.arange(count) / a.fps


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--landmarks", help=".npy, frames x (33 MediaPipe | 31 CMU) joints x 3, 4 or 5 floats")
    ap.add_argument("--fps", type=float, default=120.0, help="frame rate of the landmarks (without --times)")
    ap.add_argument("--times", help=".npy of one timestamp per frame, seconds or milliseconds")
    ap.add_argument("--teacher", default=None, help="the teacher's BVH (default: the shipped 02_01)")
    ap.add_argument("--model", default=None, help="a .kata model (default: the shipped one)")
    ap.add_argument("--chunk", type=int, default=32, help="frames pushed between two reads (a 120 Hz tracker read at ~4 Hz)")
    a = ap.parse_args()
    teacher_path = a.teacher or kata.find_data("data/cmu/02_01.bvh")
    model_path = a.model or kata.default_model_path()

    with kata.Context() as ctx:
        if a.landmarks:
            landmarks = np.load(a.landmarks).astype(np.float32)
        else:  # stand-in for a pose estimator: a recorded student without its T-pose frame
            with ctx.load_clip(kata.find_data("data/cmu/07_01.bvh")) as clip:
                landmarks = clip.all_positions(first=1)
                a.fps = 1.0 / clip.frame_time
        if landmarks.ndim != 3 or landmarks.shape[1] not in (31, 33) or landmarks.shape[2] not in (3, 4, 5):
            raise SystemExit("landmarks must be frames x 33 (MediaPipe) or 31 (CMU) joints x 3, 4 or 5 values "
                             "(got %s)" % (landmarks.shape,))
        times = times_of(a, len(landmarks))
        if landmarks.shape[1] == kata.mediapipe.LANDMARKS:
            r = kata.mediapipe.score(landmarks, times, teacher_path, model=model_path, first_frame=1, time_units="s")
            scored = r.scored
            print("%d MediaPipe frames, %d scored, %d tracking lost, %d without a person"
                  % (len(landmarks), len(scored), r.lost_frames, r.skipped_frames))
        else:
            confidences = None
            if landmarks.shape[2] > 3:  # a confidence (or visibility and presence: the smaller)
                confidences = landmarks[:, :, 3] if landmarks.shape[2] == 4 else landmarks[:, :, 3:5].min(axis=2)
            # The "cmu" layout's joint list: names and parents only, a bare live source.
            with ctx.create_layout("cmu") as student, ctx.load_model(model_path) as model, \
                    ctx.load_clip(teacher_path) as teacher, \
                    ctx.open_stream(student, layout="cmu", stencil=model.stencil, result_capacity=4 * a.chunk) as s:
                s.attach_teacher(model, clip=teacher, first_frame=1, ghost=False)
                buf = s.result_buffer(4 * a.chunk)
                xyz = np.ascontiguousarray(landmarks[:, :, :3])
                parts_read = []
                for start in range(0, len(landmarks), a.chunk):
                    s.push_many(times[start:start + a.chunk], xyz[start:start + a.chunk],
                                None if confidences is None else confidences[start:start + a.chunk])
                    r = s.read_results(buf)  # a ResultsDroppedWarning would say if any were lost
                    ok = (r.results["scored"] != 0) & (r.scores["state"] == kata.ScoreState.SCORING)
                    parts_read.append(r.scores[ok].copy())
                scored = np.concatenate(parts_read)
                print("%d landmark frames, %d scored (the first ones calibrate the body height: %.3g units)"
                      % (len(landmarks), len(scored), s.body_height))
        if not len(scored):
            raise SystemExit("no frame was scored (too short, or the timestamps' units: see --fps / --times)")
        print("mean score %.1f / 100, median %.1f; most to fix: %s"
              % (scored["score"].mean(), np.median(scored["score"]), PARTS[int(np.argmax(scored["parts"].sum(axis=0)))]))


if __name__ == "__main__":
    main()
