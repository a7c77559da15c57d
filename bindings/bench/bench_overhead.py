#!/usr/bin/python3
"""Per-frame overhead of the bindings over the C calls, measured side by side in one run.

The same stream (a CMU clip's skeleton, preset cmu, no teacher: the cheapest C work, so the binding's
share is the most visible), the same frames, the same two loops in C, Python (timeit) and C# (Mono,
Stopwatch):
  single   push one frame + read one result (kata_stream_push + kata_stream_read_results)
  chunked  push CHUNK frames (one kata_stream_push_many call from Python) + read them in one call
Each figure is a median over REPS runs of FRAMES frames; ROUNDS rounds alternate C, Python, C# so
the machine's load hits all three alike. The overhead is the binding's median minus C's, per frame.

  /usr/bin/python3 bindings/bench/bench_overhead.py [--build build] [--rounds 3] [--reps 7] [--frames 3000] [--chunk 64]
"""
import argparse
import os
import shutil
import statistics
import subprocess
import sys
import timeit

REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def parse(text):
    return {k: float(v) for k, v in (line.split() for line in text.strip().splitlines())}


def python_loops(reps, frames, chunk):
    import numpy as np
    import kata
    with kata.Context() as ctx, ctx.load_clip(os.path.join(REPO, "data/cmu/02_01.bvh")) as clip, \
            clip.skeleton() as sk, ctx.open_stream(sk) as s:
        xyz = clip.all_positions()
        dt, n_clip = clip.frame_time, len(xyz)
        one = s.result_buffer(1, ghosts=False)
        many = s.result_buffer(chunk, ghosts=False)
        state = {"t": 0.0, "f": 0}
        # Chunks of the clip (wrapping) and their timestamps, made outside the timed loop.
        order = np.arange(frames + chunk) % n_clip
        chunks_xyz = [np.ascontiguousarray(xyz[order[i:i + chunk]]) for i in range(0, frames, chunk)]

        def single():
            t, f = state["t"], state["f"]
            push, read = s.push, s.read_results
            for _ in range(frames):
                t += dt
                push(t, xyz[f])
                read(one)
                f = f + 1 if f + 1 < n_clip else 0
            state["t"], state["f"] = t, f

        def chunked():
            t = state["t"]
            for c in chunks_xyz:
                ts = t + dt * np.arange(1, chunk + 1)
                s.push_many(ts, c)
                s.read_results(many)
                t = ts[-1]
            state["t"] = t

        rounds = len(chunks_xyz) * chunk
        single_ns = statistics.median(timeit.repeat(single, number=1, repeat=reps)) * 1e9 / frames
        chunked_ns = statistics.median(timeit.repeat(chunked, number=1, repeat=reps)) * 1e9 / rounds
        return {"single": single_ns, "chunked": chunked_ns}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(REPO, "build"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--frames", type=int, default=3000)
    ap.add_argument("--chunk", type=int, default=64)
    a = ap.parse_args()
    lib_dir = os.path.join(a.build, "lib")
    os.environ.setdefault("KATA_LIBRARY", os.path.join(lib_dir, "libkata.so"))
    sys.path.insert(0, os.path.join(REPO, "bindings", "python"))
    c_exe = os.path.join(a.build, "bin", "kata_binding_bench_c")
    cs_exe = os.path.join(a.build, "bindings", "csharp", "KataBench.exe")
    have_cs = os.path.exists(cs_exe) and shutil.which("mono")
    args = [REPO, str(a.reps), str(a.frames), str(a.chunk)]
    runs = {"C": [], "Python": [], "C#": []}
    for _ in range(a.rounds):
        runs["C"].append(parse(subprocess.run([c_exe, *args], check=True, capture_output=True, text=True).stdout))
        runs["Python"].append(python_loops(a.reps, a.frames, a.chunk))
        if have_cs:
            env = dict(os.environ, LD_LIBRARY_PATH=lib_dir)
            runs["C#"].append(parse(subprocess.run(["mono", cs_exe, *args], check=True, capture_output=True,
                                                   text=True, env=env).stdout))
    med = {lang: {k: statistics.median(r[k] for r in rs) for k in ("single", "chunked")}
           for lang, rs in runs.items() if rs}
    print("ns per frame, median of %d rounds x %d reps x %d frames (chunk %d)" % (a.rounds, a.reps, a.frames, a.chunk))
    print("%-8s %12s %12s %16s %16s" % ("", "single", "chunked", "single - C", "chunked - C"))
    for lang, m in med.items():
        print("%-8s %12.1f %12.1f %16.1f %16.1f" % (lang, m["single"], m["chunked"], m["single"] - med["C"]["single"],
                                                    m["chunked"] - med["C"]["chunked"]))


if __name__ == "__main__":
    main()
