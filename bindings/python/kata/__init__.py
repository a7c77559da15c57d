"""kata: real-time 3D human pose (GPD v1 features, scoring against a teacher, retargeting).

A thin, Pythonic layer over the C ABI (sdk/include/kata/kata.h, which is the manual: units,
ownership and thread rules are the C functions'). Every method calls one C function, except the
*_many helpers, which loop over one C call per frame in Python (the C ABI has no bulk push).

    import kata, numpy as np
    with kata.Context() as ctx, ctx.load_clip("data/cmu/02_01.bvh") as clip:
        with ctx.open_stream(clip.skeleton(), preset="cmu", keep_features=True) as s:
            s.push_many(np.arange(n) * clip.frame_time, clip.all_positions())
            r = s.read_results()          # r.results, r.scores, r.ghosts, r.features: numpy

Arrays: positions are float32 (joints x 3, x y z interleaved) and are passed to C without a copy
when they are C-contiguous float32 already (else converted once per call). Results are read
straight into numpy arrays (structured dtypes mirroring kata_result / kata_score_record).
Errors: a failed call raises KataError with .status (Status) and .message (the C message).
Handles: every object has close() and is a context manager; a Context closes what was made from
it that is still open before it is destroyed (kata.h requires that order).
"""
import os

from .errors import KataError, Status
from .objects import (GPD_DIMS, GPD_JOINTS, BodyPart, Clip, Context, Model, ScoreState, Skeleton, Stencil, UpAxis,
                      default_model_path, library_path, presets, version)
from .stream import (RESULT_DTYPE, RESULT_GHOST, RESULT_SCORED, SCORE_DTYPE, ResultBuffer, Results, ScoreRecord,
                     Stream, detect_time_units)
from .retarget import Retargeter
from .messages import PracticeSection, ResultMessage, Subscriber, read_message
from .runtime import Runtime, shard_of

__all__ = ["Runtime", "shard_of", "Subscriber", "ResultMessage", "PracticeSection", "read_message", "ScoreState", "default_model_path", "Context", "Skeleton", "Clip", "Model", "Stream", "Retargeter", "ResultBuffer", "Results",
           "ScoreRecord", "KataError", "Status", "Stencil", "UpAxis", "BodyPart", "version", "library_path",
           "GPD_DIMS", "GPD_JOINTS", "RESULT_SCORED", "RESULT_GHOST", "RESULT_DTYPE", "SCORE_DTYPE", "presets",
           "detect_time_units"]

# kata.fb: the readers flatc generates from schemas/*.fbs (kata.fb.Result, ...) ship inside the
# installed package; used from a checkout, they are the build's (<repo>/build/python/kata/fb).
if not os.path.isdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), "fb")):
    _build_fb = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..",
                                              "build", "python", "kata"))
    if os.path.isdir(os.path.join(_build_fb, "fb")):
        __path__.append(_build_fb)
