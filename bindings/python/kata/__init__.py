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
import ctypes
import enum
import os
import time
import warnings
import weakref
from typing import Any, List, NamedTuple, NoReturn, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native as _n

__all__ = ["Runtime", "shard_of", "Subscriber", "ResultMessage", "PracticeSection", "read_message", "ScoreState", "default_model_path", "Context", "Skeleton", "Clip", "Model", "Stream", "Retargeter", "ResultBuffer", "Results",
           "ScoreRecord", "KataError", "Status", "Stencil", "UpAxis", "BodyPart", "version", "library_path",
           "GPD_DIMS", "GPD_JOINTS", "RESULT_SCORED", "RESULT_GHOST", "RESULT_DTYPE", "SCORE_DTYPE", "presets"]

# kata.fb: the readers flatc generates from schemas/*.fbs (kata.fb.Result, ...) ship inside the
# installed package; used from a checkout, they are the build's (<repo>/build/python/kata/fb).
if not os.path.isdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), "fb")):
    _build_fb = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..",
                                              "build", "python", "kata"))
    if os.path.isdir(os.path.join(_build_fb, "fb")):
        __path__.append(_build_fb)

GPD_DIMS = _n.GPD_DIMS
GPD_JOINTS = _n.GPD_JOINTS
RESULT_SCORED = 1
RESULT_GHOST = 2
library_path = _n.library_path
#: numpy dtypes with the exact layout of kata_result and kata_score_record (read into directly).
RESULT_DTYPE = np.dtype(_n.Result)
SCORE_DTYPE = np.dtype(_n.ScoreRecord)
assert RESULT_DTYPE.itemsize == ctypes.sizeof(_n.Result) and SCORE_DTYPE.itemsize == ctypes.sizeof(_n.ScoreRecord)


def version():
    """The loaded library's (major, minor, patch) (kata_version)."""
    return _n.version


class Status(enum.IntEnum):
    OK = 0
    NO_DATA = 1
    E_INVALID_ARGUMENT = 2
    E_NULL_POINTER = 3
    E_WRONG_JOINT_COUNT = 4
    E_NON_FINITE = 5
    E_TIMESTAMP_NOT_INCREASING = 6
    E_PARSE = 7
    E_IO = 8
    E_MODEL = 9
    E_NOT_FOUND = 10
    E_OUT_OF_MEMORY = 11
    E_BUFFER_TOO_SMALL = 12
    E_INTERNAL = 13
    E_STATE = 14
    #: not an error: the frame was accepted without features (too many joints missing)
    TRACKING_LOST = 15


class Stencil(enum.IntEnum):
    BACKWARD = 0
    CENTRAL = 1


class UpAxis(enum.IntEnum):
    """How a stream reads its frames' axes (kata_up_axis)."""
    Y = 0       #: +Y up (BVH, most engines)
    Z = 1       #: +Z up: (x, y, z) is read as (x, z, -y)
    Y_DOWN = 2  #: camera frame, x right, y down, z away (MediaPipe world landmarks, Azure Kinect)


class ScoreState(enum.IntEnum):
    """Whether a score record's scores are to be shown (kata_score_state)."""
    SCORING = 0           #: the scores are this frame's
    CALIBRATING = 1       #: the first 0.25 s after a teacher is attached or restarted
    TRACKING_LOST = 2     #: fewer than 13 of the 16 GPD joints tracked; scores are 0
    TEACHER_FINISHED = 3  #: the student has outlasted the teacher clip by 0.25 s


class BodyPart(enum.IntEnum):
    TORSO_HEAD = 0
    LEFT_ARM = 1
    RIGHT_ARM = 2
    LEFT_LEG = 3
    RIGHT_LEG = 4


class KataError(Exception):
    """A failed C call: .status (Status, or the raw int for a status this binding does not know)
    and .message (kata_*_last_error of the handle the call was made on)."""

    def __init__(self, status, message, call=""):
        try:
            self.status = Status(status)
        except ValueError:
            self.status = status
        self.message = message
        self.call = call
        name = _n.status_string(int(status)).decode()
        super().__init__("%s%s: %s" % (call + ": " if call else "", name, message))


def _text(b):
    return b.decode("utf-8") if b is not None else None


def _deprecated(old, new):
    warnings.warn("kata.Stream.%s is deprecated since 1.0 and goes in 2.0: use %s" % (old, new),
                  DeprecationWarning, stacklevel=3)


def _utf8(s):
    return None if s is None else (s if isinstance(s, bytes) else str(s).encode("utf-8"))


def default_model_path() -> str:
    """The scoring model shipped with kata: inside the installed package (kata/models/default.kata),
    else a checkout's models/default.kata."""
    here = os.path.dirname(os.path.abspath(__file__))
    for path in (os.path.join(here, "models", "default.kata"),
                 os.path.normpath(os.path.join(here, "..", "..", "..", "models", "default.kata"))):
        if os.path.isfile(path):
            return path
    raise FileNotFoundError("kata: no default.kata inside the package (%s/models) nor in a checkout; "
                            "pass a model path" % here)


def presets() -> List[str]:
    """Names of the built-in layouts (kata_layout_name): every joint-map preset ("cmu", ...), then
    "mediapipe". Each is a valid open_stream(preset=...); create_layout makes the skeleton of
    "mediapipe", "gpd", "azure-kinect" and "xsens"."""
    out: List[str] = []
    i = 0
    while True:
        name = _n.layout_name(i)
        if name is None:
            return out
        out.append(name.decode())
        i += 1


_addressof = ctypes.addressof
_c_char_from_buffer = ctypes.c_char.from_buffer


def _address(a):
    """The data pointer of a C-contiguous array: 3x cheaper than a.ctypes.data (measured 0.7 vs
    2.0 us), which also fills numpy's ctypes caches; read-only arrays take the slow path."""
    try:
        return _addressof(_c_char_from_buffer(a))
    except (TypeError, ValueError):
        return a.ctypes.data


def _positions_f32(positions, joints=None):
    """positions as a C-contiguous float32 array (no copy when it already is one)."""
    a = np.ascontiguousarray(positions, dtype=np.float32)
    if joints is not None and a.size != 3 * joints:
        raise ValueError("expected %d joints x 3 floats, got %d floats" % (joints, a.size))
    return a


def _time_units_code(units):
    if units == "s":
        return 0  # KATA_TIME_SECONDS
    if units == "ms":
        return 1  # KATA_TIME_MILLISECONDS
    raise ValueError('time_units must be "s" or "ms" (or "auto" for a whole recording), not %r' % (units,))


def detect_time_units(timestamps):
    """kata_time_units_detect: "s" or "ms" for recorded timestamps (n >= 2, increasing) from the
    median step between frames (2..1000 Hz is plausible); raises KataError when it fits neither."""
    ts = np.ascontiguousarray(timestamps, dtype=np.float64)
    out = ctypes.c_int(0)
    status = _n.time_units_detect(ts.ctypes.data, ts.size, ctypes.byref(out))
    if status:
        raise KataError(status, _text(_n.context_last_error(None)), "kata_time_units_detect")
    return "ms" if out.value == 1 else "s"


class _Handle:
    """An owned C handle released exactly once (close(), the with block, or garbage collection)."""
    _release: Any = None  # the C release function, set per subclass

    def __init__(self, handle, context):
        self._h = handle
        self._context = context  # keeps the context alive while this object is
        if context is not None:
            context._children.add(self)

    @property
    def handle(self) -> int:
        """The raw C handle (an int), for calls this binding does not wrap."""
        if not self._h:
            raise ValueError("%s is closed" % type(self).__name__)
        return self._h

    @property
    def closed(self) -> bool:
        return not self._h

    def close(self) -> None:
        h, self._h = self._h, None
        if h:
            type(self)._release(h)
            if self._context is not None:
                self._context._children.discard(self)

    def __enter__(self):
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown: the module may already be gone
            pass


class Context(_Handle):
    """The library instance (kata_context_create). Objects made from it keep it alive."""
    _release = _n.context_destroy

    def __init__(self):
        self._children = weakref.WeakSet()
        h = ctypes.c_void_p()
        status = _n.context_create(ctypes.byref(h))
        if status:
            raise KataError(status, "cannot create a context", "kata_context_create")
        super().__init__(h.value, None)

    def close(self) -> None:
        for child in list(self._children):  # kata.h: every object must be released first
            child.close()
        super().close()

    def _check(self, status, call):
        if status and status != Status.NO_DATA:
            raise KataError(status, _text(_n.context_last_error(self._h)), call)
        return status

    def _make(self, cls, call, fn, *args):
        h = ctypes.c_void_p()
        self._check(fn(self.handle, *args, ctypes.byref(h)), call)
        return cls(h.value, self)

    # -- constructors (one C call each) --
    def create_skeleton(self, names, parents, rest_offsets=None):
        """kata_skeleton_create: names (str), parents (-1 for the root, topological order), rest
        offsets (joints x 3, parent-relative, input units) or None for a bare live source."""
        n = len(names)
        c_names = (ctypes.c_char_p * n)(*[_utf8(x) for x in names])
        par = np.ascontiguousarray(parents, dtype=np.int32)
        if par.size != n:
            raise ValueError("parents must have one entry per joint")
        rest = None
        if rest_offsets is not None:
            rest = np.ascontiguousarray(rest_offsets, dtype=np.float64)
            if rest.size != 3 * n:
                raise ValueError("rest_offsets must be joints x 3")
        return self._make(Skeleton, "kata_skeleton_create", _n.skeleton_create, n, c_names, par.ctypes.data,
                          None if rest is None else rest.ctypes.data)

    def create_layout(self, layout: str) -> "Skeleton":
        """kata_skeleton_create_layout: the joint list of a built-in layout as a skeleton without
        rest pose: "mediapipe" (33 landmarks in MediaPipe's order, metres, camera axes), "gpd"
        (16 GPD joints), "azure-kinect" (32 joints, millimetres: stream with UpAxis.Y_DOWN),
        "xsens" (23 segments, metres: UpAxis.Z). Unknown names raise E_NOT_FOUND. [any thread]"""
        return self._make(Skeleton, "kata_skeleton_create_layout", _n.skeleton_create_layout, _utf8(layout))

    def load_skeleton_bvh(self, path: str) -> "Skeleton":
        """kata_skeleton_load_bvh: the HIERARCHY of a BVH file."""
        return self._make(Skeleton, "kata_skeleton_load_bvh", _n.skeleton_load_bvh, _utf8(path))

    def load_clip(self, path: str) -> "Clip":
        """kata_clip_load_bvh: a BVH clip (a malformed file raises E_PARSE naming file and line)."""
        return self._make(Clip, "kata_clip_load_bvh", _n.clip_load_bvh, _utf8(path))

    def load_model(self, path: str) -> "Model":
        """kata_model_load: a verified .kata model (a refused file raises E_MODEL with the reason)."""
        return self._make(Model, "kata_model_load", _n.model_load, _utf8(path))

    def load_model_bytes(self, data: bytes) -> "Model":
        """kata_model_load_memory: a model from bytes (copied)."""
        data = bytes(data)
        return self._make(Model, "kata_model_load_memory", _n.model_load_memory, data, len(data))

    def open_stream(self, skeleton, preset="cmu", name_map=None, stencil=None, up_axis=None, max_gap=None,
                    history_capacity=None, body_height=None, calibration_frames=None, result_capacity=None,
                    keep_features=None, name_map_text=None):
        """kata_stream_open with a kata_stream_desc: arguments left None keep kata_stream_desc_init's
        defaults. Give a preset name (a layout, see presets()), name_map (a file path) or
        name_map_text (the contents of a name-map file; kata_stream_open_name_map), only one.
        up_axis: UpAxis (ignored for "mediapipe", which is always camera axes). max_gap: seconds.
        body_height: input units, 0 = estimated. [any thread]"""
        d = _n.StreamDesc()
        _n.stream_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
        if d.struct_size != ctypes.sizeof(_n.StreamDesc):
            raise ImportError("kata_stream_desc layout differs from this binding's (%d vs %d bytes)"
                              % (d.struct_size, ctypes.sizeof(_n.StreamDesc)))
        d.preset = None if (name_map is not None or name_map_text is not None) else _utf8(preset)
        d.name_map_path = _utf8(name_map)
        for field, value in (("stencil", stencil), ("up_axis", up_axis), ("max_gap", max_gap),
                             ("history_capacity", history_capacity), ("body_height", body_height),
                             ("calibration_frames", calibration_frames), ("result_capacity", result_capacity),
                             ("keep_features", keep_features)):
            if value is not None:
                setattr(d, field, int(value) if field in ("stencil", "up_axis", "keep_features") else value)
        if name_map_text is not None:
            s = self._make(Stream, "kata_stream_open_name_map", _n.stream_open_name_map, skeleton.handle,
                           ctypes.byref(d), _utf8(name_map_text))
        else:
            s = self._make(Stream, "kata_stream_open", _n.stream_open, skeleton.handle, ctypes.byref(d))
        s._joints = skeleton.joint_count
        return s

    def create_runtime(self, workers: Optional[int] = None, max_streams: Optional[int] = None,
                       max_joints: Optional[int] = None, queue_capacity: Optional[int] = None,
                       publish: Optional[str] = None, send_hwm: Optional[int] = None, ingest: Optional[str] = None,
                       ingest_pull: Optional[bool] = None, max_message_bytes: Optional[int] = None,
                       skeleton_resend_seconds: Optional[float] = None) -> "Runtime":
        """kata_runtime_create: many streams on worker threads, every result published on ZeroMQ.
        publish: comma-separated endpoints to bind ("tcp://127.0.0.1:*" picks a free port: see
        Runtime.publish_endpoint); ingest: endpoints to read frames from ("bind:" prefix binds).
        Arguments left None keep kata_runtime_desc_init's defaults. [any thread]"""
        d = _n.RuntimeDesc()
        _n.runtime_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
        for field, value in (("workers", workers), ("max_streams", max_streams), ("max_joints", max_joints),
                             ("queue_capacity", queue_capacity), ("send_hwm", send_hwm),
                             ("max_message_bytes", max_message_bytes),
                             ("skeleton_resend_seconds", skeleton_resend_seconds)):
            if value is not None:
                setattr(d, field, value)
        d.publish_endpoints = _utf8(publish)
        d.ingest_endpoints = _utf8(ingest)
        if ingest_pull is not None:
            d.ingest_pull = 1 if ingest_pull else 0
        return self._make(Runtime, "kata_runtime_create", _n.runtime_create, ctypes.byref(d))

    def create_retargeter(self, student, **options):
        """kata_retargeter_create: student is a Skeleton with rest offsets. options: preset ("cmu" or
        "gpd"), gradient_tolerance, max_iterations, warm_start, restore_bone_lengths."""
        d = _retarget_desc(options)
        r = self._make(Retargeter, "kata_retargeter_create", _n.retargeter_create, student.handle, ctypes.byref(d))
        r._student_joints = student.joint_count
        return r

    def create_retargeter_for_stream(self, stream, **options):
        """kata_retargeter_create_for_stream: the stream's skeleton is the student."""
        d = _retarget_desc(options)
        r = self._make(Retargeter, "kata_retargeter_create_for_stream", _n.retargeter_create_for_stream,
                       stream.handle, ctypes.byref(d))
        r._student_joints = stream._joints
        return r


def _retarget_desc(options):
    d = _n.RetargetDesc()
    _n.retarget_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
    for key, value in options.items():
        if key not in ("preset", "gradient_tolerance", "max_iterations", "warm_start", "restore_bone_lengths"):
            raise TypeError("unknown retarget option %r" % key)
        setattr(d, key, _utf8(value) if key == "preset" else (int(value) if key != "gradient_tolerance" else value))
    return d


class Skeleton(_Handle):
    """An immutable joint tree (kata_skeleton)."""
    _release = _n.skeleton_destroy

    @property
    def joint_count(self) -> int:
        return _n.skeleton_joint_count(self.handle)

    @property
    def names(self) -> List[str]:
        return [_text(_n.skeleton_joint_name(self.handle, i)) for i in range(self.joint_count)]

    @property
    def parents(self) -> np.ndarray:
        return np.array([_n.skeleton_joint_parent(self.handle, i) for i in range(self.joint_count)], dtype=np.int32)

    @property
    def offsets(self) -> Optional[np.ndarray]:
        """Rest offsets (joints, 3) float64 from each parent, skeleton units (the root's: its rest
        position), by kata_skeleton_joint_offset; None for a bare live source (no rest pose)."""
        out = np.empty((self.joint_count, 3), dtype=np.float64)
        h = self.handle
        for i in range(self.joint_count):
            status = _n.skeleton_joint_offset(h, i, out[i].ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
            if status == Status.E_STATE:
                return None
            if status:
                raise KataError(status, "joint %d" % i, "kata_skeleton_joint_offset")
        return out


class Clip(_Handle):
    """A recorded motion (kata_clip): a BVH file with its skeleton."""
    _release = _n.clip_destroy
    _joints = None

    @property
    def frame_count(self) -> int:
        return _n.clip_frame_count(self.handle)

    @property
    def frame_time(self) -> float:
        return _n.clip_frame_time(self.handle)

    @property
    def joint_count(self) -> int:
        """Joints of the clip's skeleton."""
        if self._joints is None:
            with self.skeleton() as sk:
                self._joints = sk.joint_count
        return self._joints

    def skeleton(self) -> "Skeleton":
        """kata_clip_skeleton: a new Skeleton handle (closed by its own close())."""
        h = ctypes.c_void_p()
        status = _n.clip_skeleton(self.handle, ctypes.byref(h))
        if status:
            raise KataError(status, "cannot copy the clip's skeleton", "kata_clip_skeleton")
        return Skeleton(h.value, self._context)

    def positions(self, frame: int, out: Optional[np.ndarray] = None) -> np.ndarray:
        """kata_clip_positions: world positions (joints x 3 float32) of one frame, into out if given."""
        if out is None:
            out = np.empty((self.joint_count, 3), dtype=np.float32)
        if out.dtype != np.float32 or not out.flags.c_contiguous:
            raise ValueError("out must be a C-contiguous float32 array")
        status = _n.clip_positions(self.handle, frame, out.ctypes.data, out.size)
        if status:
            raise KataError(status, "frame %d of %d (buffer %d floats)" % (frame, self.frame_count, out.size),
                            "kata_clip_positions")
        return out

    def all_positions(self, first: int = 0) -> np.ndarray:
        """Positions of frames first..end as (frames, joints, 3) float32: one kata_clip_positions per frame."""
        joints = self.joint_count
        frames = self.frame_count - first
        out = np.empty((max(frames, 0), joints, 3), dtype=np.float32)
        h, size = self.handle, 3 * joints
        base, stride = out.ctypes.data, out.strides[0] if frames > 0 else 0
        for i in range(frames):
            status = _n.clip_positions(h, first + i, base + i * stride, size)
            if status:
                raise KataError(status, "frame %d" % (first + i), "kata_clip_positions")
        return out


class Model(_Handle):
    """A loaded, verified scoring model (kata_model); shareable by any number of streams."""
    _release = _n.model_free

    @property
    def rank(self) -> int:
        return _n.model_rank(self.handle)

    @property
    def delta_star(self) -> float:
        return _n.model_delta_star(self.handle)

    @property
    def stencil(self) -> Stencil:
        return Stencil(_n.model_stencil(self.handle))

    def metadata(self, key: str) -> Optional[str]:
        """kata_model_metadata: "layout", "date", "data", "parameters"; None for an unknown key."""
        return _text(_n.model_metadata(self.handle, _utf8(key)))


class ScoreRecord:
    """One scored frame (kata_score_record), as plain Python values."""
    __slots__ = ("matched_reference_frame", "frame_index", "timestamp", "distance", "score", "parts",
                 "part_scores", "part_to_fix", "state")

    def __init__(self, rec):
        self.matched_reference_frame = rec.matched_reference_frame
        self.frame_index = rec.frame_index
        self.timestamp = rec.timestamp
        self.distance = rec.distance
        self.score = rec.score
        self.parts = tuple(rec.parts)
        self.part_scores = tuple(rec.part_scores)
        self.part_to_fix = rec.part_to_fix
        self.state = rec.state

    def __repr__(self):
        return "ScoreRecord(frame=%d, score=%.2f, distance=%.5g)" % (self.frame_index, self.score, self.distance)


class ResultBuffer:
    """Preallocated arrays that Stream.read_results fills in place (no allocation per read):
    results (capacity,) RESULT_DTYPE, scores (capacity,) SCORE_DTYPE, ghosts (capacity, G, 3)
    float32 where G = the stream's ghost joint count, features (capacity, 1683) float32 when
    with_features. The views a read returns stay valid until the next read into this buffer."""

    def __init__(self, capacity, ghost_joints=0, with_scores=True, with_features=False):
        self.capacity = int(capacity)
        self.results = np.zeros(self.capacity, dtype=RESULT_DTYPE)
        self.results["struct_size"] = RESULT_DTYPE.itemsize
        self.scores = None
        if with_scores:
            self.scores = np.zeros(self.capacity, dtype=SCORE_DTYPE)
            self.scores["struct_size"] = SCORE_DTYPE.itemsize
        self.ghosts = np.zeros((self.capacity, ghost_joints, 3), dtype=np.float32) if ghost_joints else None
        self.features = np.zeros((self.capacity, GPD_DIMS), dtype=np.float32) if with_features else None
        # The C call's arguments, computed once.
        self._args = (_address(self.results), None if self.scores is None else _address(self.scores),
                      None if self.ghosts is None else _address(self.ghosts),
                      0 if self.ghosts is None else self.ghosts.size,
                      None if self.features is None else _address(self.features),
                      0 if self.features is None else self.features.size, self.capacity)
        self._count = ctypes.c_uint32()
        self._count_ref = ctypes.byref(self._count)


class Results:
    """What one read_results call moved: numpy views (results, scores, ghosts, features; None
    when not requested), `len()` results long."""
    __slots__ = ("results", "scores", "ghosts", "features")

    def __init__(self, buf, n):
        self.results = buf.results[:n]
        self.scores = None if buf.scores is None else buf.scores[:n]
        self.ghosts = None if buf.ghosts is None else buf.ghosts[:n]
        self.features = None if buf.features is None else buf.features[:n]

    def __len__(self):
        return len(self.results)


class Stream(_Handle):
    """A live pose stream (kata_stream): frames in, features / scores / ghosts out. Used by one
    thread at a time (kata.h)."""
    _release = _n.stream_close
    _joints = 0

    def _raise(self, status: int, call: str) -> NoReturn:
        raise KataError(status, _text(_n.stream_last_error(self._h)), call)

    @property
    def joint_count(self) -> int:
        return self._joints

    def push(self, timestamp: float, positions: Any, confidences: Any = None) -> Status:
        """kata_stream_push (or kata_stream_push_confidence with confidences): one frame, timestamp
        in seconds (must increase by at least KATA_MIN_TIME_STEP), positions (joints, 3) in input
        units (float32 C-contiguous is passed without a copy; other arrays are converted), and
        optionally one confidence per joint (e.g. MediaPipe visibility; below the gate's threshold
        or NaN: the joint is missing and held). Returns Status.OK, or Status.TRACKING_LOST (accepted
        without features: too many joints missing). A refused frame raises KataError and changes
        nothing. Does not allocate in C. [stream owner: one thread at a time]"""
        a = positions
        if type(a) is not np.ndarray or a.dtype != np.float32 or not a.flags.c_contiguous:
            a = _positions_f32(a)
        if confidences is None:
            status = _n.stream_push(self.handle, timestamp, _address(a), a.size // 3)
        else:
            c = confidences
            if type(c) is not np.ndarray or c.dtype != np.float32 or not c.flags.c_contiguous:
                c = np.ascontiguousarray(c, dtype=np.float32)
            if c.size * 3 != a.size:
                raise ValueError("confidences: one per joint (%d), got %d" % (a.size // 3, c.size))
            status = _n.stream_push_confidence(self.handle, timestamp, _address(a), _address(c), a.size // 3)
        if status and status != Status.TRACKING_LOST:
            self._raise(status, "kata_stream_push_confidence" if confidences is not None else "kata_stream_push")
        return Status(status)

    def push_landmarks(self, timestamp, values, time_units="s"):
        """kata_stream_push_landmarks: one frame in a landmark source's own shape, values
        (joints, 3|4|5) float32: x y z [confidence | MediaPipe's visibility presence, read as
        confidence = the smaller]; timestamp in time_units "s" or "ms"."""
        a = np.ascontiguousarray(values, dtype=np.float32)
        if a.ndim != 2 or a.shape[0] != self._joints or a.shape[1] not in (3, 4, 5):
            raise ValueError("values must be (%d joints, 3, 4 or 5 channels)" % self._joints)
        status = _n.stream_push_landmarks(self.handle, timestamp, _time_units_code(time_units), _address(a),
                                          a.shape[0], a.shape[1])
        if status not in (0, Status.TRACKING_LOST):
            self._raise(status, "kata_stream_push_landmarks")
        return status

    def push_many(self, timestamps: Any, positions: Any, confidences: Any = None, time_units: Any = None) -> int:
        """Pushes frames i = 0..n-1: timestamps (n,) seconds, positions (n, joints, 3) float32 and
        optionally confidences (n, joints), in one kata_stream_push_many call (no copy of
        positions when already C-contiguous float32). A refused frame raises KataError
        naming its index; the frames before it were pushed. Returns the frames reported
        TRACKING_LOST (accepted without features). [stream owner]
        MediaPipe's shapes: positions (n, joints, 4 or 5) (x y z confidence, or x y z visibility
        presence: confidence = the smaller) and time_units "s", "ms" or "auto" (from the steps
        between frames, kata_time_units_detect: refused when they fit neither unit) go through
        kata_stream_push_landmarks (frames tracking lost are accepted)."""
        if time_units is not None or np.ndim(positions) == 3 and np.shape(positions)[2] in (4, 5):
            if confidences is not None:
                raise ValueError("confidences go in the positions' 4th/5th channel with time_units")
            return self._push_many_landmarks(timestamps, positions, "s" if time_units is None else time_units)
        a = _positions_f32(positions)
        ts = np.ascontiguousarray(timestamps, dtype=np.float64)
        n = len(ts)
        joints = self._joints
        if a.size != n * 3 * joints:
            raise ValueError("positions must be %d frames x %d joints x 3" % (n, joints))
        cbase = None
        if confidences is not None:
            c = np.ascontiguousarray(confidences, dtype=np.float32)
            if c.size != n * joints:
                raise ValueError("confidences must be %d frames x %d joints" % (n, joints))
            cbase = c.ctypes.data
        # One call for the whole chunk (kata_stream_push_many): the per-call cost of ctypes is paid
        # once, not per frame.
        pushed, lost = ctypes.c_uint32(0), ctypes.c_uint32(0)
        status = _n.stream_push_many(self.handle, ts.ctypes.data, a.ctypes.data, cbase, joints, n,
                                     ctypes.byref(pushed), ctypes.byref(lost))
        if status:
            raise KataError(status, "frame %d: %s" % (pushed.value, _text(_n.stream_last_error(self.handle))),
                            "kata_stream_push_many")
        return lost.value

    def set_confidence_gate(self, threshold: float = 0.5, max_hold: float = 0.5,
                            max_missing_share: float = 0.25) -> None:
        """kata_stream_set_confidence_gate: a GPD joint below `threshold` (or NaN) is missing and
        held at its last good position for at most `max_hold` seconds; more than
        max_missing_share x 16 joints missing (or one missing longer) is TRACKING_LOST. Takes effect
        at the next push. [stream owner]"""
        status = _n.stream_set_confidence_gate(self.handle, threshold, max_hold, max_missing_share)
        if status:
            self._raise(status, "kata_stream_set_confidence_gate")

    def set_smoothing(self, enabled: bool = True, min_cutoff: float = 2.0, beta: float = 1.0,
                      d_cutoff: float = 1.0) -> None:
        """kata_stream_set_smoothing: the One-Euro filter on the 16 mapped joints (cutoff =
        min_cutoff + beta x |speed| Hz, speed in input units per second low-passed at d_cutoff Hz).
        On by default for "mediapipe" (2 Hz, 1.0, 1 Hz), off otherwise. [stream owner]"""
        status = _n.stream_set_smoothing(self.handle, 1 if enabled else 0, min_cutoff, beta, d_cutoff)
        if status:
            self._raise(status, "kata_stream_set_smoothing")

    @property
    def lost_frames(self) -> int:
        """Frames reported TRACKING_LOST so far (kata_stream_lost_frames). [stream owner]"""
        return int(_n.stream_lost_frames(self.handle))

    def bone_lengths(self) -> Optional[Tuple[np.ndarray, np.ndarray]]:
        """kata_stream_bone_lengths: (lengths, spread), each (16,) float64 in input units, GPD joint
        order (lengths[0] = 0), estimated from the first 60 frames whose 16 joints are all good
        (noise-corrected; kata.h); None until those frames were seen. [stream owner]"""
        lengths = np.zeros(GPD_JOINTS, dtype=np.float64)
        spread = np.zeros(GPD_JOINTS, dtype=np.float64)
        status = _n.stream_bone_lengths(self.handle, lengths.ctypes.data, spread.ctypes.data, GPD_JOINTS)
        if status == Status.NO_DATA:
            return None
        if status:
            self._raise(status, "kata_stream_bone_lengths")
        return lengths, spread

    def _push_many_landmarks(self, timestamps, values, time_units):
        a = np.ascontiguousarray(values, dtype=np.float32)
        ts = np.ascontiguousarray(timestamps, dtype=np.float64)
        n = len(ts)
        if a.ndim != 3 or a.shape[0] != n or a.shape[1] != self._joints or a.shape[2] not in (3, 4, 5):
            raise ValueError("values must be (%d frames, %d joints, 3, 4 or 5 channels)" % (n, self._joints))
        if time_units == "auto":
            time_units = detect_time_units(ts)
        units = _time_units_code(time_units)
        push, h, joints, channels = _n.stream_push_landmarks, self.handle, self._joints, a.shape[2]
        base, stride = _address(a), 4 * joints * channels
        lost = 0
        for i, t in enumerate(ts.tolist()):
            status = push(h, t, units, base + i * stride, joints, channels)
            if status == Status.TRACKING_LOST:
                lost += 1
            elif status:
                raise KataError(status, "frame %d: %s" % (i, _text(_n.stream_last_error(h))), "kata_stream_push_landmarks")
        return lost

    def flush(self) -> None:
        """kata_stream_flush: end of a take."""
        status = _n.stream_flush(self.handle)
        if status:
            self._raise(status, "kata_stream_flush")

    def reset(self) -> None:
        """kata_stream_reset: the next frame starts a new segment."""
        status = _n.stream_reset(self.handle)
        if status:
            self._raise(status, "kata_stream_reset")

    def features(self, out=None):
        """kata_stream_features: (vector float32[1683], timestamp, frame_index) of the newest
        feature vector, or None before the first one. out: a float32[1683] to fill."""
        if out is None:
            out = np.empty(GPD_DIMS, dtype=np.float32)
        elif out.dtype != np.float32 or not out.flags.c_contiguous or out.size < GPD_DIMS:
            raise ValueError("out must be a C-contiguous float32 array of %d values" % GPD_DIMS)
        t, frame = ctypes.c_double(), ctypes.c_int64()
        status = _n.stream_features(self.handle, out.ctypes.data, out.size, ctypes.byref(t), ctypes.byref(frame))
        if status == Status.NO_DATA:
            return None
        if status:
            self._raise(status, "kata_stream_features")
        return out, t.value, frame.value

    @property
    def feature_count(self) -> int:
        return _n.stream_feature_count(self.handle)

    @property
    def body_height(self) -> float:
        return _n.stream_body_height(self.handle)

    # -- the teacher: what the stream is compared with --
    def attach_teacher(self, model, clip=None, skeleton=None, positions=None, frame_time=None, preset=None,
                       first_frame=0, pose_frame=-1, ghost=None, features=None, joints=None, body_height=0.0,
                       **retarget):
        """kata_stream_attach_teacher: score against (and ghost from) a teacher given as one of
        a Clip; a Skeleton + positions (frames, joints, 3) + frame_time; GPD features
        (frames, 1683) + frame_time; or joints, one held pose of the 16 GPD joints (16, 3) with its
        body_height. pose_frame >= first_frame: that frame only, as a single pose. ghost: default
        True for a clip or positions (features and joints have none to make). retarget: the ghost
        solver's options (preset "cmu"/"gpd", gradient_tolerance, max_iterations, warm_start,
        restore_bone_lengths)."""
        d = _n.TeacherDesc()
        _n.teacher_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
        d.model = model.handle
        keep = []
        if clip is not None:
            d.clip = clip.handle
        if skeleton is not None:
            d.skeleton = skeleton.handle
        if positions is not None:
            p = _positions_f32(positions)
            keep.append(p)
            d.positions = p.ctypes.data
            d.frames = p.shape[0]
        if features is not None:
            f = np.ascontiguousarray(features, dtype=np.float32)
            if f.size == 0 or f.size % GPD_DIMS:
                raise ValueError("features must be frames x %d" % GPD_DIMS)
            keep.append(f)
            d.features = f.ctypes.data
            d.frames = f.size // GPD_DIMS
        if joints is not None:
            j = np.ascontiguousarray(joints, dtype=np.float32)
            if j.size != 3 * GPD_JOINTS:
                raise ValueError("joints must be %d x 3 (the 16 GPD joints, GPD order)" % GPD_JOINTS)
            keep.append(j)
            d.joints = j.ctypes.data
            d.frames = 1
            d.body_height = body_height
        if frame_time is not None:
            d.frame_time = frame_time
        d.preset = _utf8(preset)
        d.first_frame = first_frame
        d.pose_frame = pose_frame
        if ghost is None:
            ghost = features is None and joints is None
        d.ghost = 1 if ghost else 0
        rdesc = _retarget_desc(retarget) if retarget else None
        if rdesc is not None:
            d.retarget = ctypes.pointer(rdesc)
        status = _n.stream_attach_teacher(self.handle, ctypes.byref(d))
        del keep  # copied by the call
        if status:
            self._raise(status, "kata_stream_attach_teacher")

    def detach_teacher(self) -> None:
        """kata_stream_detach_teacher: later results are not scored and carry no ghost."""
        status = _n.stream_detach_teacher(self.handle)
        if status:
            self._raise(status, "kata_stream_detach_teacher")

    def restart_teacher(self) -> None:
        """kata_stream_restart_teacher: the next frame is matched from the teacher's first frame."""
        status = _n.stream_restart_teacher(self.handle)
        if status:
            self._raise(status, "kata_stream_restart_teacher")

    def read_newest(self, buffer=None):
        """kata_stream_read_newest: the newest unread result (older unread ones are passed over) as
        a Results of length 1, or None when nothing is unread. buffer: a result_buffer(1) to reuse
        (no allocation per call)."""
        if buffer is None:
            buffer = ResultBuffer(1, self.ghost_joint_count, True, False)
        a = buffer._args
        status = _n.stream_read_newest(self.handle, a[0], a[1], a[2], a[3], a[4], a[5])
        if status == Status.NO_DATA:
            return None
        if status:
            self._raise(status, "kata_stream_read_newest")
        return Results(buffer, 1)

    # -- deprecated since 1.0 (removed in 2.0, not before 2027-06-01): the 0.x reference calls --
    def set_reference_pose(self, model, features):
        """Deprecated: attach_teacher(model, features=f, pose_frame=0)."""
        _deprecated("set_reference_pose", "attach_teacher(model, features=..., pose_frame=0)")
        self.attach_teacher(model, features=np.asarray(features).reshape(1, GPD_DIMS), pose_frame=0)

    def set_reference_joints(self, model, joints, body_height):
        """Deprecated: attach_teacher(model, joints=j, body_height=h)."""
        _deprecated("set_reference_joints", "attach_teacher(model, joints=..., body_height=...)")
        self.attach_teacher(model, joints=joints, body_height=body_height)

    def set_reference_clip(self, model, features, frame_time):
        """Deprecated: attach_teacher(model, features=f, frame_time=t)."""
        _deprecated("set_reference_clip", "attach_teacher(model, features=..., frame_time=...)")
        self.attach_teacher(model, features=features, frame_time=frame_time)

    def set_reference_bvh(self, model, clip, preset="cmu", first_frame=0, pose_frame=-1):
        """Deprecated: attach_teacher(model, clip=c, ..., ghost=False)."""
        _deprecated("set_reference_bvh", "attach_teacher(model, clip=..., ghost=False)")
        self.attach_teacher(model, clip=clip, preset=preset, first_frame=first_frame, pose_frame=pose_frame,
                            ghost=False)

    def clear_reference(self):
        """Deprecated: detach_teacher()."""
        _deprecated("clear_reference", "detach_teacher()")
        self.detach_teacher()

    def restart_reference(self):
        """Deprecated: restart_teacher()."""
        _deprecated("restart_reference", "restart_teacher()")
        self.restart_teacher()

    def score(self):
        """Deprecated: read_newest() (or read_results() for every frame). The newest frame's
        ScoreRecord (read or not), or None before the first vector (kata_stream_score)."""
        _deprecated("score", "read_newest()")
        rec = _n.ScoreRecord()
        rec.struct_size = ctypes.sizeof(rec)
        status = _n.stream_score(self.handle, ctypes.byref(rec))
        if status == Status.NO_DATA:
            return None
        if status:
            self._raise(status, "kata_stream_score")
        return ScoreRecord(rec)

    # -- results --
    @property
    def ghost_joint_count(self) -> int:
        return _n.stream_ghost_joint_count(self.handle)

    @property
    def ghost_joint_sources(self) -> np.ndarray:
        """Student skeleton joint index of each ghost joint (kata_stream_ghost_joint_source)."""
        h = self.handle
        return np.array([_n.stream_ghost_joint_source(h, i) for i in range(_n.stream_ghost_joint_count(h))],
                        dtype=np.int32)

    @property
    def results_pending(self) -> int:
        return _n.stream_results_pending(self.handle)

    @property
    def results_dropped(self) -> int:
        return _n.stream_results_dropped(self.handle)

    def result_buffer(self, capacity=None, scores=True, ghosts=True, features=False):
        """A ResultBuffer sized for this stream (capacity default: every result the ring can hold)."""
        if capacity is None:
            capacity = max(self.results_pending, 64)
        return ResultBuffer(capacity, self.ghost_joint_count if ghosts else 0, scores, features)

    def read_results(self, buffer=None, features=False):
        """kata_stream_read_results: moves every unread result (oldest first, at most the buffer's
        capacity) into numpy arrays and returns them as Results. Without a buffer, fresh arrays
        sized for what is pending are made (features only when asked and the stream keeps them)."""
        if buffer is None:
            buffer = ResultBuffer(max(_n.stream_results_pending(self.handle), 1), self.ghost_joint_count, True,
                                  features)
        status = _n.stream_read_results(self.handle, *buffer._args, buffer._count_ref)
        if status:
            self._raise(status, "kata_stream_read_results")
        return Results(buffer, buffer._count.value)


class Retargeter(_Handle):
    """Per-student retargeting state (kata_retargeter); one thread at a time."""
    _release = _n.retargeter_destroy
    _student_joints = 0

    def _raise(self, status: int, call: str) -> NoReturn:
        raise KataError(status, _text(_n.retargeter_last_error(self._h)), call)

    @property
    def joint_count(self) -> int:
        return _n.retargeter_joint_count(self.handle)

    @property
    def joint_sources(self) -> np.ndarray:
        h = self.handle
        return np.array([_n.retargeter_joint_source(h, i) for i in range(_n.retargeter_joint_count(h))],
                        dtype=np.int32)

    def solve(self, teacher, out=None):
        """kata_retargeter_solve: one teacher frame (skeleton joints x 3) -> (ghost (joint_count, 3)
        float32, info dict)."""
        t = _positions_f32(teacher)
        if out is None:
            out = np.empty((self.joint_count, 3), dtype=np.float32)
        info = _n.RetargetInfo()
        info.struct_size = ctypes.sizeof(info)
        status = _n.retargeter_solve(self.handle, t.ctypes.data, t.size // 3, out.ctypes.data, out.size,
                                     ctypes.byref(info))
        if status:
            self._raise(status, "kata_retargeter_solve")
        return out, {name: getattr(info, name) for name, _ in _n.RetargetInfo._fields_[1:]}

    def place(self, student, ghost):
        """kata_retargeter_place: moves ghost (in place) over the student's posture."""
        s = _positions_f32(student)
        if ghost.dtype != np.float32 or not ghost.flags.c_contiguous:
            raise ValueError("ghost must be a C-contiguous float32 array (from solve)")
        status = _n.retargeter_place(self.handle, s.ctypes.data, s.size // 3, ghost.ctypes.data, ghost.size)
        if status:
            self._raise(status, "kata_retargeter_place")
        return ghost

    @property
    def rotation_joint_count(self) -> int:
        """Joints the local rotations cover (the student skeleton's); 0 without a rest pose."""
        return int(_n.retargeter_rotation_joint_count(self.handle))

    def local_rotations(self, ghost: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """kata_retargeter_local_rotations: the ghost (from solve) as what a game engine animates:
        (rotations (J, 4) float32 unit quaternions x, y, z, w (w >= 0), each relative to its parent,
        the root's world; root_position (3,); positions (J, 3), every joint's forward kinematics;
        residual, the largest ghost-to-FK distance, student units). J = rotation_joint_count.
        E_STATE without a rest pose. [retargeter owner]"""
        g = _positions_f32(ghost)
        j = self.rotation_joint_count
        rotations = np.empty((j, 4), dtype=np.float32)
        root = np.empty(3, dtype=np.float32)
        positions = np.empty((j, 3), dtype=np.float32)
        residual = ctypes.c_double()
        status = _n.retargeter_local_rotations(self.handle, g.ctypes.data, g.size, rotations.ctypes.data,
                                               rotations.size, root.ctypes.data, positions.ctypes.data,
                                               positions.size, ctypes.byref(residual))
        if status:
            self._raise(status, "kata_retargeter_local_rotations")
        return rotations, root, positions, residual.value

    def reset(self) -> None:
        status = _n.retargeter_reset(self.handle)
        if status:
            self._raise(status, "kata_retargeter_reset")


# ---- messages: a subscriber of a runtime's (or `kata serve`'s) results ------------------------------

class PracticeSection(NamedTuple):
    """The practice setting a result was computed under (schemas/result.fbs PracticeSection): the
    teacher section followed, in teacher seconds from the teacher's first frame (the axis of
    matched_teacher_time), its ends rounded to teacher frames; loop: looped; revision: the practice
    message's (Runtime.set_practice's) revision, 0 for the stream's configured setting."""
    start_time: float
    end_time: float
    loop: bool
    revision: int


class ResultMessage:
    """One result message (kata_result_message) as Python values: stream_id, result_sequence,
    frame_sequence, frame_index, capture_ns (source clock), arrival_ns / computed_ns /
    published_ns (CLOCK_MONOTONIC ns on the runtime's host), scored, matched_teacher_frame,
    matched_teacher_time (seconds from the teacher's first frame, -1 unless scored), distance
    (dimensionless), score (0..100), parts (split of d^2), part_scores, part_to_fix (BodyPart or
    -1), state (ScoreState), ghost ((G, 3) float32 copy, or None), practice (the PracticeSection it
    was computed under; None without a clip teacher or from an older runtime)."""
    __slots__ = ("stream_id", "result_sequence", "frame_sequence", "frame_index", "capture_ns", "arrival_ns",
                 "computed_ns", "published_ns", "scored", "matched_teacher_frame", "matched_teacher_time",
                 "distance", "score", "parts", "part_scores", "part_to_fix", "state", "ghost", "practice")
    stream_id: int
    result_sequence: int
    frame_sequence: int
    frame_index: int
    capture_ns: int
    arrival_ns: int
    computed_ns: int
    published_ns: int
    matched_teacher_frame: int
    matched_teacher_time: float
    practice: Optional[PracticeSection]
    distance: float
    score: float
    part_to_fix: int
    state: int

    def __init__(self, m: "_n.ResultMessage") -> None:
        for name in ("stream_id", "result_sequence", "frame_sequence", "frame_index", "capture_ns", "arrival_ns",
                     "computed_ns", "published_ns", "matched_teacher_frame", "matched_teacher_time", "distance",
                     "score", "part_to_fix", "state"):
            setattr(self, name, getattr(m, name))
        self.practice = (PracticeSection(m.practice_start_time, m.practice_end_time, bool(m.practice_loop),
                                         m.practice_revision) if m.has_practice else None)
        self.scored = bool(m.scored)
        self.parts = tuple(m.parts)
        self.part_scores = tuple(m.part_scores)
        # The C ghost pointer is valid only until this thread's next call: copied now.
        self.ghost = (np.ctypeslib.as_array(m.ghost, shape=(m.ghost_joint_count, 3)).copy()
                      if m.ghost_joint_count and m.ghost else None)

    def __repr__(self) -> str:
        return "ResultMessage(stream=%d, seq=%d, score=%.2f)" % (self.stream_id, self.result_sequence, self.score)


_message = _n.ResultMessage()


def read_message(message: bytes) -> Optional[ResultMessage]:
    """kata_message_read_result: one ZeroMQ message of a kata runtime (16-byte topic + FlatBuffer),
    checked by the FlatBuffers verifier. A ResultMessage; None for a valid message that is not a
    result (a skeleton definition); KataError E_PARSE for a refused one (truncated, corrupt).
    [any thread]"""
    m = _n.ResultMessage()
    m.struct_size = ctypes.sizeof(m)
    data = bytes(message)
    status = _n.message_read_result(data, len(data), ctypes.byref(m))
    if status == Status.NO_DATA:
        return None
    if status:
        raise KataError(status, "message of %d bytes refused" % len(data), "kata_message_read_result")
    return ResultMessage(m)


class Subscriber:
    """A ZeroMQ SUB socket on a runtime's publish endpoint (Debian's python3-zmq), decoding result
    messages with kata_message_read_result. stream: only that stream id (its topic), or all.
    Skeleton definitions and refused messages are counted (skipped, refused), never returned.

        with kata.Subscriber("tcp://127.0.0.1:5556") as sub:
            msg = sub.receive(timeout=1.0)   # a ResultMessage, or None after 1 s without one

    One thread at a time (ZeroMQ sockets are not thread-safe)."""

    def __init__(self, endpoint: str, stream: Optional[int] = None, receive_hwm: int = 100000) -> None:
        import zmq  # python3-zmq: only a subscriber needs it
        self._zmq = zmq
        self._socket = zmq.Context.instance().socket(zmq.SUB)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.RCVHWM, receive_hwm)
        self._socket.setsockopt(zmq.SUBSCRIBE, b"" if stream is None else b"%016x" % stream)
        self._socket.connect(endpoint)
        self._poller = zmq.Poller()
        self._poller.register(self._socket, zmq.POLLIN)
        self.skipped = 0  #: valid messages that are not results (skeleton definitions)
        self.refused = 0  #: messages the verifier refused

    def receive(self, timeout: Optional[float] = None) -> Optional[ResultMessage]:
        """The next result message; None when none arrives within timeout seconds (None: wait)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            wait = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not self._poller.poll(None if wait is None else int(wait * 1000)):
                return None
            try:
                m = read_message(self._socket.recv())
            except KataError:
                self.refused += 1
                continue
            if m is None:
                self.skipped += 1
                continue
            return m

    def close(self) -> None:
        self._socket.close(0)

    def __enter__(self) -> "Subscriber":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class Runtime(_Handle):
    """Many streams, ZeroMQ in and out (kata_runtime). push may be called from any thread (one
    producer per stream keeps its order); it never blocks: a full worker queue drops and counts."""
    _release = _n.runtime_destroy

    def add_stream(self, stream_id: int, stream: "Stream", preset: Optional[str] = None,
                   publish_features: bool = False) -> None:
        """kata_runtime_add_stream: hands `stream` to the runtime under stream_id; the runtime owns
        it afterwards (the Stream object is closed here without freeing it). preset: the joint map
        named in the published skeleton definition (None: "cmu"). [any thread]"""
        h = ctypes.c_void_p(stream.handle)
        status = _n.runtime_add_stream(self.handle, stream_id, ctypes.byref(h), _utf8(preset),
                                       1 if publish_features else 0)
        if status:
            raise KataError(status, _text(_n.context_last_error(self._context.handle)), "kata_runtime_add_stream")
        stream._h = None  # owned by the runtime now
        if stream._context is not None:
            stream._context._children.discard(stream)
        self._joints = getattr(self, "_joints", {})
        self._joints[stream_id] = stream._joints

    def push(self, stream_id: int, sequence: int, capture_time: float, positions: Any) -> None:
        """kata_runtime_push: queues one frame (capture_time seconds, increasing; positions
        (joints, 3) float32). KataError E_NOT_FOUND (no such stream), E_STATE (queue full: dropped
        and counted). Never blocks, never allocates in C. [any thread]"""
        a = positions
        if type(a) is not np.ndarray or a.dtype != np.float32 or not a.flags.c_contiguous:
            a = _positions_f32(a)
        status = _n.runtime_push(self.handle, stream_id, sequence, capture_time, _address(a), a.size // 3)
        if status:
            raise KataError(status, "stream %d frame %d" % (stream_id, sequence), "kata_runtime_push")

    def set_practice(self, stream_id: int, revision: int, teacher_start: float = 0.0,
                     loop: Optional[Tuple[float, float]] = None) -> None:
        """kata_runtime_set_practice: from the frames pushed after it, the stream follows its clip
        teacher from teacher_start seconds, or loops the section loop = (start, end) seconds
        (teacher seconds from its first frame, as ResultMessage.matched_teacher_time); every result
        then carries practice.revision == revision. KataError E_NOT_FOUND (no such stream),
        E_INVALID_ARGUMENT (not finite, negative, outside the clip, an empty loop), E_STATE (no clip
        teacher; the worker queue full). Never blocks. [any thread]"""
        a, b = loop if loop is not None else (0.0, 0.0)
        status = _n.runtime_set_practice(self.handle, stream_id, revision, teacher_start, 1 if loop is not None else 0,
                                         a, b)
        if status:
            raise KataError(status, _text(_n.context_last_error(self._context.handle)), "kata_runtime_set_practice")

    def stop(self) -> None:
        """kata_runtime_stop: finishes every queued frame, publishes every result, stops the threads."""
        status = _n.runtime_stop(self.handle)
        if status:
            raise KataError(status, "stop failed", "kata_runtime_stop")

    def counters(self) -> dict:
        """kata_runtime_get_counters as a dict (streams, frames_in, queue_full, refused, results,
        results_dropped, published, ingest_*). [any thread]"""
        c = _n.RuntimeCounters()
        c.struct_size = ctypes.sizeof(c)
        status = _n.runtime_get_counters(self.handle, ctypes.byref(c))
        if status:
            raise KataError(status, "counters", "kata_runtime_get_counters")
        return {name: getattr(c, name) for name, _ in _n.RuntimeCounters._fields_[1:]}

    @property
    def publish_endpoint(self) -> str:
        """The endpoint the publisher bound last, resolved (a "*" port shows its number)."""
        return _text(_n.runtime_publish_endpoint(self.handle)) or ""

    @property
    def ingest_endpoint(self) -> str:
        return _text(_n.runtime_ingest_endpoint(self.handle)) or ""


def shard_of(stream_id: int, shard_count: int) -> int:
    """kata_shard_of: the shard (0..shard_count-1) that scores stream_id (FNV-1a; stable)."""
    return int(_n.shard_of(stream_id, shard_count))
