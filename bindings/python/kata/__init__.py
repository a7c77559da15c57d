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
import warnings
import weakref

import numpy as np

from . import _native as _n

__all__ = ["Context", "Skeleton", "Clip", "Model", "Stream", "Retargeter", "ResultBuffer", "Results",
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


class Stencil(enum.IntEnum):
    BACKWARD = 0
    CENTRAL = 1


class UpAxis(enum.IntEnum):
    Y = 0
    Z = 1


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


def presets():
    """Names of the built-in joint-map presets (kata_preset_name)."""
    out, i = [], 0
    while True:
        name = _n.preset_name(i)
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


class _Handle:
    """An owned C handle released exactly once (close(), the with block, or garbage collection)."""
    _release = None  # the C release function, set per subclass

    def __init__(self, handle, context):
        self._h = handle
        self._context = context  # keeps the context alive while this object is
        if context is not None:
            context._children.add(self)

    @property
    def handle(self):
        """The raw C handle (an int), for calls this binding does not wrap."""
        if not self._h:
            raise ValueError("%s is closed" % type(self).__name__)
        return self._h

    @property
    def closed(self):
        return not self._h

    def close(self):
        h, self._h = self._h, None
        if h:
            type(self)._release(h)
            if self._context is not None:
                self._context._children.discard(self)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
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

    def close(self):
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

    def load_skeleton_bvh(self, path):
        """kata_skeleton_load_bvh: the HIERARCHY of a BVH file."""
        return self._make(Skeleton, "kata_skeleton_load_bvh", _n.skeleton_load_bvh, _utf8(path))

    def load_clip(self, path):
        """kata_clip_load_bvh: a BVH clip (a malformed file raises E_PARSE naming file and line)."""
        return self._make(Clip, "kata_clip_load_bvh", _n.clip_load_bvh, _utf8(path))

    def load_model(self, path):
        """kata_model_load: a verified .kata model (a refused file raises E_MODEL with the reason)."""
        return self._make(Model, "kata_model_load", _n.model_load, _utf8(path))

    def load_model_bytes(self, data):
        """kata_model_load_memory: a model from bytes (copied)."""
        data = bytes(data)
        return self._make(Model, "kata_model_load_memory", _n.model_load_memory, data, len(data))

    def open_stream(self, skeleton, preset="cmu", name_map=None, stencil=None, up_axis=None, max_gap=None,
                    history_capacity=None, body_height=None, calibration_frames=None, result_capacity=None,
                    keep_features=None):
        """kata_stream_open with a kata_stream_desc: arguments left None keep kata_stream_desc_init's
        defaults. Give a preset name or name_map (a file path), not both."""
        d = _n.StreamDesc()
        _n.stream_desc_init(ctypes.byref(d))
        if d.struct_size != ctypes.sizeof(_n.StreamDesc):
            raise ImportError("kata_stream_desc layout differs from this binding's (%d vs %d bytes)"
                              % (d.struct_size, ctypes.sizeof(_n.StreamDesc)))
        d.preset = None if name_map is not None else _utf8(preset)
        d.name_map_path = _utf8(name_map)
        for field, value in (("stencil", stencil), ("up_axis", up_axis), ("max_gap", max_gap),
                             ("history_capacity", history_capacity), ("body_height", body_height),
                             ("calibration_frames", calibration_frames), ("result_capacity", result_capacity),
                             ("keep_features", keep_features)):
            if value is not None:
                setattr(d, field, int(value) if field in ("stencil", "up_axis", "keep_features") else value)
        s = self._make(Stream, "kata_stream_open", _n.stream_open, skeleton.handle, ctypes.byref(d))
        s._joints = skeleton.joint_count
        return s

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
    _n.retarget_desc_init(ctypes.byref(d))
    for key, value in options.items():
        if key not in ("preset", "gradient_tolerance", "max_iterations", "warm_start", "restore_bone_lengths"):
            raise TypeError("unknown retarget option %r" % key)
        setattr(d, key, _utf8(value) if key == "preset" else (int(value) if key != "gradient_tolerance" else value))
    return d


class Skeleton(_Handle):
    """An immutable joint tree (kata_skeleton)."""
    _release = _n.skeleton_destroy

    @property
    def joint_count(self):
        return _n.skeleton_joint_count(self.handle)

    @property
    def names(self):
        return [_text(_n.skeleton_joint_name(self.handle, i)) for i in range(self.joint_count)]

    @property
    def parents(self):
        return np.array([_n.skeleton_joint_parent(self.handle, i) for i in range(self.joint_count)], dtype=np.int32)


class Clip(_Handle):
    """A recorded motion (kata_clip): a BVH file with its skeleton."""
    _release = _n.clip_destroy
    _joints = None

    @property
    def frame_count(self):
        return _n.clip_frame_count(self.handle)

    @property
    def frame_time(self):
        return _n.clip_frame_time(self.handle)

    @property
    def joint_count(self):
        """Joints of the clip's skeleton."""
        if self._joints is None:
            with self.skeleton() as sk:
                self._joints = sk.joint_count
        return self._joints

    def skeleton(self):
        """kata_clip_skeleton: a new Skeleton handle (closed by its own close())."""
        h = ctypes.c_void_p()
        status = _n.clip_skeleton(self.handle, ctypes.byref(h))
        if status:
            raise KataError(status, "cannot copy the clip's skeleton", "kata_clip_skeleton")
        return Skeleton(h.value, self._context)

    def positions(self, frame, out=None):
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

    def all_positions(self, first=0):
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
    def rank(self):
        return _n.model_rank(self.handle)

    @property
    def delta_star(self):
        return _n.model_delta_star(self.handle)

    @property
    def stencil(self):
        return Stencil(_n.model_stencil(self.handle))

    def metadata(self, key):
        """kata_model_metadata: "layout", "date", "data", "parameters"; None for an unknown key."""
        return _text(_n.model_metadata(self.handle, _utf8(key)))


class ScoreRecord:
    """One scored frame (kata_score_record), as plain Python values."""
    __slots__ = ("matched_reference_frame", "frame_index", "timestamp", "distance", "score", "parts")

    def __init__(self, rec):
        self.matched_reference_frame = rec.matched_reference_frame
        self.frame_index = rec.frame_index
        self.timestamp = rec.timestamp
        self.distance = rec.distance
        self.score = rec.score
        self.parts = tuple(rec.parts)

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

    def _raise(self, status, call):
        raise KataError(status, _text(_n.stream_last_error(self._h)), call)

    @property
    def joint_count(self):
        return self._joints

    def push(self, timestamp, positions):
        """kata_stream_push: one frame (joints x 3 float32; other dtypes are converted)."""
        a = positions
        if type(a) is not np.ndarray or a.dtype != np.float32 or not a.flags.c_contiguous:
            a = _positions_f32(a)
        status = _n.stream_push(self.handle, timestamp, _address(a), a.size // 3)
        if status:
            self._raise(status, "kata_stream_push")

    def push_many(self, timestamps, positions):
        """Pushes frames i = 0..n-1: timestamps (n,), positions (n, joints, 3) float32, with one
        kata_stream_push per frame (no copy of positions when already C-contiguous float32). A
        refused frame raises KataError naming its index; the frames before it were pushed."""
        a = _positions_f32(positions)
        ts = np.ascontiguousarray(timestamps, dtype=np.float64)
        n = len(ts)
        if a.size != n * 3 * self._joints:
            raise ValueError("positions must be %d frames x %d joints x 3" % (n, self._joints))
        push, h, joints = _n.stream_push, self.handle, self._joints
        base, stride = a.ctypes.data, 12 * joints
        for i, t in enumerate(ts.tolist()):
            status = push(h, t, base + i * stride, joints)
            if status:
                raise KataError(status, "frame %d: %s" % (i, _text(_n.stream_last_error(h))), "kata_stream_push")
        return n

    def flush(self):
        """kata_stream_flush: end of a take."""
        status = _n.stream_flush(self.handle)
        if status:
            self._raise(status, "kata_stream_flush")

    def reset(self):
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
    def feature_count(self):
        return _n.stream_feature_count(self.handle)

    @property
    def body_height(self):
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
        _n.teacher_desc_init(ctypes.byref(d))
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

    def detach_teacher(self):
        """kata_stream_detach_teacher: later results are not scored and carry no ghost."""
        status = _n.stream_detach_teacher(self.handle)
        if status:
            self._raise(status, "kata_stream_detach_teacher")

    def restart_teacher(self):
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
    def ghost_joint_count(self):
        return _n.stream_ghost_joint_count(self.handle)

    @property
    def ghost_joint_sources(self):
        """Student skeleton joint index of each ghost joint (kata_stream_ghost_joint_source)."""
        h = self.handle
        return np.array([_n.stream_ghost_joint_source(h, i) for i in range(_n.stream_ghost_joint_count(h))],
                        dtype=np.int32)

    @property
    def results_pending(self):
        return _n.stream_results_pending(self.handle)

    @property
    def results_dropped(self):
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

    def _raise(self, status, call):
        raise KataError(status, _text(_n.retargeter_last_error(self._h)), call)

    @property
    def joint_count(self):
        return _n.retargeter_joint_count(self.handle)

    @property
    def joint_sources(self):
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

    def reset(self):
        status = _n.retargeter_reset(self.handle)
        if status:
            self._raise(status, "kata_retargeter_reset")
