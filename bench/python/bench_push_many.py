#!/usr/bin/python3
"""Python's chunked push against C, side by side in one run (<= 1 us per frame over C).

Each repetition opens two fresh streams on the same clip and pushes the same N frames into both:
  C       one kata_stream_push_many call through ctypes for the whole chunk (the C loop; the one
          ctypes call is amortised over N frames),
  Python  Stream.push_many (the binding's checks, numpy conversions, the same C call),
  loop    the old per-frame path (one ctypes kata_stream_push per frame), for reference,
in alternating order. Prints the medians per frame, Python - C per frame, and the load average.

  /usr/bin/python3 bench/python/bench_push_many.py [--frames 2000] [--repetitions 15]
(KATA_LIBRARY=build/lib/libkata.so by default from a checkout)."""
import argparse, ctypes, os, statistics, sys, time

REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
sys.path.insert(0, os.path.join(REPO, "bindings", "python"))
os.environ.setdefault("KATA_LIBRARY", os.path.join(REPO, "build", "lib", "libkata.so"))
import numpy as np  # noqa: E402
import kata  # noqa: E402
from kata import _native as _n  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--frames", type=int, default=2000)
parser.add_argument("--repetitions", type=int, default=15)
parser.add_argument("--clip", default=os.path.join(REPO, "data", "cmu", "07_01.bvh"))
args = parser.parse_args()

ctx = kata.Context()
clip = ctx.load_clip(args.clip)
skeleton = clip.skeleton()
frames = min(args.frames, clip.frame_count)
positions = np.ascontiguousarray(clip.all_positions()[:frames], dtype=np.float32)
joints = positions.shape[1]
timestamps = np.arange(frames, dtype=np.float64) * clip.frame_time


def run_c(stream):
    pushed, lost = ctypes.c_uint32(0), ctypes.c_uint32(0)
    t = time.perf_counter()
    status = _n.stream_push_many(stream.handle, timestamps.ctypes.data, positions.ctypes.data, None, joints, frames,
                                 ctypes.byref(pushed), ctypes.byref(lost))
    dt = time.perf_counter() - t
    assert status == 0 and pushed.value == frames, (status, pushed.value)
    return dt


def run_python(stream):
    t = time.perf_counter()
    stream.push_many(timestamps, positions)
    return time.perf_counter() - t


def run_loop(stream):
    h, base, stride, push = stream.handle, positions.ctypes.data, 12 * joints, _n.stream_push
    t = time.perf_counter()
    for i, ts in enumerate(timestamps.tolist()):
        status = push(h, ts, base + i * stride, joints)
        assert status in (0, int(kata.Status.TRACKING_LOST)), status
    return time.perf_counter() - t


runs = {"C": run_c, "Python": run_python, "loop": run_loop}
times = {name: [] for name in runs}
for rep in range(args.repetitions):
    order = list(runs) if rep % 2 == 0 else list(reversed(list(runs)))
    for name in order:
        stream = ctx.open_stream(skeleton, layout="cmu")
        times[name].append(runs[name](stream) / frames * 1e6)
        stream.close()
median = {name: statistics.median(v) for name, v in times.items()}
over = statistics.median([p - c for p, c in zip(times["Python"], times["C"])])
print("frames per chunk %d, repetitions %d, load average %s" % (frames, args.repetitions,
                                                                " ".join("%.2f" % x for x in os.getloadavg())))
for name in runs:
    print("  %-7s median %.3f us per frame" % (name, median[name]))
print("  Python - C: %.3f us per frame (median of the pairs; target <= 1 us)" % over)
print("  per-frame ctypes loop - C: %.3f us per frame" % (median["loop"] - median["C"]))
