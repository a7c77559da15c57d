#!/usr/bin/env python3
"""Prints kata results as they arrive: a plain ZeroMQ SUB socket (Debian's python3-zmq) and the
readers flatc --python generates from the installed schemas (python3-flatbuffers).

  python3 python_subscriber.py --endpoint tcp://127.0.0.1:5556 [--stream ID] [--count N] [--timeout S]
                       [--python-dir DIR]   # where kata/fb/ lives, when none of the below finds it
                       [--key ME.secret --server-key SERVER.pub]   # CURVE (kata keygen; docs/deploy.md)

The readers come from the kata Python package the running python3 imports (a venv with
`pip install ./bindings/python`, or PYTHONPATH), else from the places this file may sit in: a
checkout's build/python (samples/ beside build/) or an install (PREFIX/share/kata/samples: the
package in PREFIX/lib/python3.X/dist-packages or site-packages). --python-dir is needed only
elsewhere.

Every kata message is one ZeroMQ frame: 16 bytes of topic (the stream id as lowercase hex, so
subscribing to one stream's topic selects it) and then the FlatBuffer; its file identifier
(bytes 4..8 of the buffer) says which table it is. Ages use CLOCK_MONOTONIC, the clock the
runtime stamps results with (valid on the runtime's host)."""
import argparse
import os
import re
import sys
import time

import zmq

TOPIC = 16
# Result.part_to_fix and Result.feedback_state (schemas/result.fbs) by name.
PARTS = ("torso_head", "left_arm", "right_arm", "left_leg", "right_leg")
STATES = {1: "calibrating", 2: "tracking lost", 3: "teacher finished"}


def read_key_file(path):
    """The public (and secret) key of a `kata keygen` file: lines `public = "..."`, `secret = "..."`."""
    keys = dict(re.findall(r'^\s*(public|secret)\s*=\s*"([^"]{40})"', open(path).read(), re.M))
    if "public" not in keys:
        raise SystemExit("%s: no public key" % path)
    return keys


def import_readers(python_dir):
    """Makes kata.fb importable: --python-dir, the package this python3 has, a checkout's build or
    the install this file is part of (see the module)."""
    if python_dir:
        sys.path.insert(0, python_dir)
    try:
        import kata.fb.Result  # noqa: F401
        return
    except ImportError:
        pass
    here = os.path.dirname(os.path.abspath(__file__))
    version = "python%d.%d" % sys.version_info[:2]
    prefix = os.path.normpath(os.path.join(here, "..", "..", ".."))  # PREFIX/share/kata/samples
    tried = [os.path.join(here, "..", "build", "python")] + [
        os.path.join(prefix, lib, version, kind) for lib in ("lib", "lib64", "local/lib")
        for kind in ("dist-packages", "site-packages")]
    for d in tried:
        if os.path.isfile(os.path.join(d, "kata", "fb", "Result.py")):
            sys.path.insert(0, os.path.normpath(d))
            for name in [m for m in sys.modules if m == "kata" or m.startswith("kata.")]:
                del sys.modules[name]
            return
    raise SystemExit("python_subscriber: the kata message readers (kata.fb) are not importable by %s: install the kata "
                     "package for it (pip install ./bindings/python, or cmake --install), or pass --python-dir "
                     "(tried %s)" % (sys.executable, ", ".join(os.path.normpath(d) for d in tried)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--endpoint", required=True)
    ap.add_argument("--stream", type=int, default=None, help="only this stream id")
    ap.add_argument("--count", type=int, default=0, help="exit after this many results (0: run until Ctrl-C)")
    ap.add_argument("--timeout", type=float, default=0.0, help="exit 1 when nothing arrives for this long (s)")
    ap.add_argument("--python-dir", default=os.environ.get("KATA_PYTHON_DIR", ""))
    ap.add_argument("--key", help="CURVE: this subscriber's key pair (kata keygen's .secret)")
    ap.add_argument("--server-key", help="CURVE: the server's public key (.pub)")
    args = ap.parse_args()
    import_readers(args.python_dir)
    from kata.fb.Result import Result
    from kata.fb.SkeletonDefinition import SkeletonDefinition
    from kata.fb.Repetition import Repetition

    sub = zmq.Context.instance().socket(zmq.SUB)
    if args.key or args.server_key:
        if not (args.key and args.server_key):
            raise SystemExit("CURVE needs both --key and --server-key")
        own = read_key_file(args.key)
        if "secret" not in own:
            raise SystemExit("%s: not a .secret file" % args.key)
        sub.curve_publickey = own["public"].encode()
        sub.curve_secretkey = own["secret"].encode()
        sub.curve_serverkey = read_key_file(args.server_key)["public"].encode()
    sub.setsockopt(zmq.SUBSCRIBE, b"" if args.stream is None else b"%016x" % args.stream)
    sub.connect(args.endpoint)
    poller = zmq.Poller()
    poller.register(sub, zmq.POLLIN)
    seen = 0
    while args.count == 0 or seen < args.count:
        if not poller.poll(int(args.timeout * 1000) if args.timeout > 0 else None):
            print("no message for %.1f s" % args.timeout, file=sys.stderr)
            return 1
        message = sub.recv()
        received_ns = time.clock_gettime_ns(time.CLOCK_MONOTONIC)
        body = message[TOPIC:]
        kind = body[4:8]
        if kind == b"KSKL":
            d = SkeletonDefinition.GetRootAs(body, 0)
            print("stream %d: skeleton of %d joints (layout %s)" % (d.StreamId(), d.JointNamesLength(),
                  (d.Layout() or b"").decode()), flush=True)
        elif kind == b"KRES":
            r = Result.GetRootAs(body, 0)
            age_us = (received_ns - r.ArrivalTime().Nanoseconds()) / 1000.0
            if r.Scored():
                fix = r.PartToFix()
                print("stream %d result %d frame %d: score %.1f (distance %.4f, teacher frame %d at %.2f s, ghost %d "
                      "joints) age %.0f us, fix %s" % (r.StreamId(), r.ResultSequence(), r.FrameSequence(), r.Score(),
                                                     r.Distance(), r.MatchedTeacherFrame(), r.MatchedTeacherTime(),
                                                     r.GhostLength(), age_us, PARTS[fix] if 0 <= fix < 5 else "-"),
                      flush=True)
            else:
                why = STATES.get(r.FeedbackState())
                print("stream %d result %d frame %d: not scored%s, age %.0f us" % (r.StreamId(), r.ResultSequence(),
                      r.FrameSequence(), " (%s)" % why if why else "", age_us), flush=True)
            seen += 1
        elif kind == b"KREP":  # a repetition ended (docs/coach/repetitions.md), after its frame's result
            p = Repetition.GetRootAs(body, 0)
            print("stream %d repetition %d%s: %.2f-%.2f s, tempo %.2f, score %.1f, knees %s deg (teacher %s)" % (
                p.StreamId(), p.Index(), " (partial)" if p.Partial() else "", p.StartTime(), p.EndTime(), p.Tempo(),
                p.Score(), "/".join("%.0f" % p.Range(k) for k in range(min(2, p.RangeLength()))),
                "/".join("%.0f" % p.TeacherRange(k) for k in range(min(2, p.TeacherRangeLength())))), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
