"""The library instance and the immutable things made from it: Context (kata_context), Skeleton,
Clip (a BVH recording), Model (a scoring model), the shared enums, and where the shipped model is."""
import ctypes
import enum
import os
import weakref
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence, Tuple, Type, TypeVar

import numpy as np

from . import _native as _n
from ._util import _text, _typed, _utf8
from .errors import KataError, Status

if TYPE_CHECKING:
    from .retarget import Retargeter
    from .runtime import Runtime
    from .stream import Stream

__all__ = ["Context", "Skeleton", "Clip", "Model", "Teacher", "Landmarks", "Stencil", "UpAxis", "ScoreState", "BodyPart", "CueAction",
           "default_model_path", "find_data", "layouts", "version", "library_path", "GPD_DIMS", "GPD_JOINTS"]

GPD_DIMS = _n.GPD_DIMS
GPD_JOINTS = _n.GPD_JOINTS
#: The loaded libkata's file and its (major, minor, patch) (kata_version): plain values, both.
library_path: str = _n.library_path
version: Tuple[int, int, int] = _n.version



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


class CueAction(enum.IntEnum):
    """What a correction cue says to do at its joint (kata_cue_action; -1: no cue)."""
    BEND = 0        #: bend the knee / elbow more, or lean the chest / lower back forward
    STRAIGHTEN = 1  #: the opposite of bend
    RAISE = 2       #: raise the limb (shoulder, hip) or the head (neck)
    LOWER = 3       #: the opposite of raise
    TURN = 4        #: mostly sideways or a twist


def _share_dirs() -> List[str]:
    """Where kata's shared files may be, in order: inside the package (a wheel: models/), the
    install prefix's share/kata (`cmake --install`), a build tree's share/kata and the checkout
    (the package used from bindings/python)."""
    here = os.path.dirname(os.path.abspath(__file__))
    dirs = [here]
    try:
        from . import _install_paths  # type: ignore[attr-defined]  # written by `cmake --install`
        dirs.append(os.path.normpath(os.path.join(here, _install_paths.DATADIR_FROM_PACKAGE)))
    except (ImportError, AttributeError):
        pass
    repo = os.path.normpath(os.path.join(here, "..", "..", ".."))
    dirs += [os.path.join(repo, "build", "share", "kata"), repo]
    return dirs


def find_data(relative: str) -> str:
    """The path of one of kata's shared files, e.g. "models/default.kata" or "data/cmu/05_18.bvh"
    (the clips `cmake --install` puts in PREFIX/share/kata): as the CLI does, first where the
    program runs (relative to the current folder), then inside the package (a wheel carries the
    model), in the install's share/kata, then in a build tree and checkout the package is used
    from. Raises FileNotFoundError naming every place looked in."""
    if os.path.isfile(relative):
        return os.path.abspath(relative)
    looked = [os.getcwd()]
    for d in _share_dirs():
        path = os.path.join(d, relative)
        if os.path.isfile(path):
            return path
        looked.append(d)
    raise FileNotFoundError("kata: no %s in %s" % (relative, ", ".join(looked)))


def default_model_path() -> str:
    """The scoring model shipped with kata (find_data("models/default.kata")): inside the
    package (a wheel), the install's share/kata/models, or a checkout's models/."""
    return find_data(os.path.join("models", "default.kata"))


def layouts() -> List[str]:
    """Names of the built-in layouts (kata_layout_name): every joint-name map ("cmu", ...), then
    "mediapipe". Each is a valid open_stream(layout=...); create_layout makes the skeleton of
    "mediapipe", "gpd", "azure-kinect" and "xsens"."""
    out: List[str] = []
    i = 0
    while True:
        name = _n.layout_name(i)
        if name is None:
            return out
        out.append(name.decode("utf-8", "replace"))
        i += 1



_H = TypeVar("_H", bound="_Handle")


class _Handle:
    """An owned C handle released exactly once (close(), the with block, or garbage collection)."""
    _release: Any = None  # the C release function, set per subclass

    def __init__(self, handle: Optional[int], context: Optional["Context"]) -> None:
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

    def __enter__(self: _H) -> _H:
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

    def __init__(self) -> None:
        self._children: "weakref.WeakSet[_Handle]" = weakref.WeakSet()
        h = ctypes.c_void_p()
        status = _n.context_create(ctypes.byref(h))
        if status:
            raise KataError(status, "cannot create a context", "kata_context_create")
        super().__init__(h.value, None)

    def close(self) -> None:
        for child in list(self._children):  # kata.h: every object must be released first
            child.close()
        super().close()

    def _check(self, status: int, call: str) -> int:
        if status and status != Status.NO_DATA:
            raise KataError(status, _text(_n.context_last_error(self._h)), call)
        return status

    def _make(self, cls: Type[_H], call: str, fn: Any, *args: Any) -> _H:
        h = ctypes.c_void_p()
        self._check(fn(self.handle, *args, ctypes.byref(h)), call)
        return cls(h.value, self)

    # -- constructors (one C call each) --
    def create_skeleton(self, names: Sequence[str], parents: Any, rest_offsets: Any = None) -> "Skeleton":
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

    @_typed
    def load_landmarks(self, path: str, layout: str = "mediapipe", fps: float = 0.0,
                       time_units: Optional[str] = None) -> "Landmarks":
        """kata_landmarks_load (1.1): a landmark recording of a built-in layout ("mediapipe", "gpd",
        "azure-kinect", "xsens"), .npy (frames, joints, 3..5) with its "X.times.npy" beside it, or
        .csv, read as `kata score` does. fps: the frame rate of a recording without timestamps;
        time_units: "s", "ms", or None to infer them from the steps (kata_time_units_detect).
        KataError E_IO, E_PARSE, E_NOT_FOUND (unknown layout), E_INVALID_ARGUMENT. [any thread]"""
        units = {None: -1, "s": 0, "ms": 1}.get(time_units)
        if units is None:
            raise ValueError("time_units must be 's', 'ms' or None, not %r" % (time_units,))
        return self._make(Landmarks, "kata_landmarks_load", _n.landmarks_load, _utf8(path), _utf8(layout),
                          fps, units)

    def open_stream(self, skeleton: "Skeleton", layout: Optional[str] = "cmu", name_map: Optional[str] = None,
                    stencil: Optional[int] = None, up_axis: Optional[int] = None, max_gap: Optional[float] = None,
                    history_capacity: Optional[int] = None, body_height: Optional[float] = None,
                    calibration_frames: Optional[int] = None, result_capacity: Optional[int] = None,
                    keep_features: Optional[bool] = None, name_map_text: Optional[str] = None,
                    on_drop: Optional[str] = None) -> "Stream":
        """kata_stream_open with a kata_stream_desc: arguments left None keep kata_stream_desc_init's
        defaults. Give a layout name (see layouts()), name_map (a file path) or
        name_map_text (the contents of a name-map file; kata_stream_open_name_map), only one.
        up_axis: UpAxis (ignored for "mediapipe", which is always camera axes). max_gap: seconds.
        body_height: input units, 0 = estimated. result_capacity: results kept until read (64).
        on_drop: what a read does about results lost to a full ring ("warn", "raise", "count";
        Stream.on_drop). [any thread]"""
        from . import stream as _stream  # stream.py builds on this module
        d = _n.StreamDesc()
        _n.stream_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
        if d.struct_size != ctypes.sizeof(_n.StreamDesc):
            raise ImportError("kata_stream_desc layout differs from this binding's (%d vs %d bytes)"
                              % (d.struct_size, ctypes.sizeof(_n.StreamDesc)))
        d.layout = None if (name_map is not None or name_map_text is not None) else _utf8(layout)
        d.name_map_path = _utf8(name_map)
        for field, value in (("stencil", stencil), ("up_axis", up_axis), ("max_gap", max_gap),
                             ("history_capacity", history_capacity), ("body_height", body_height),
                             ("calibration_frames", calibration_frames), ("result_capacity", result_capacity),
                             ("keep_features", keep_features)):
            if value is not None:
                setattr(d, field, int(value) if field in ("stencil", "up_axis", "keep_features") else value)
        if name_map_text is not None:
            s = self._make(_stream.Stream, "kata_stream_open_name_map", _n.stream_open_name_map, skeleton.handle,
                           ctypes.byref(d), _utf8(name_map_text))
        else:
            s = self._make(_stream.Stream, "kata_stream_open", _n.stream_open, skeleton.handle, ctypes.byref(d))
        s._joints = skeleton.joint_count
        s._result_capacity = int(d.result_capacity)
        if on_drop is not None:
            s.on_drop = on_drop
        return s

    def create_runtime(self, workers: Optional[int] = None, max_streams: Optional[int] = None,
                       max_joints: Optional[int] = None, queue_capacity: Optional[int] = None,
                       publish: Optional[str] = None, send_hwm: Optional[int] = None, ingest: Optional[str] = None,
                       ingest_pull: Optional[bool] = None, max_message_bytes: Optional[int] = None,
                       skeleton_resend_seconds: Optional[float] = None,
                       max_frame_age_seconds: Optional[float] = None, direct_ingest: bool = False,
                       on_stream_open: Any = None, stream_stencil: Optional[int] = None) -> "Runtime":
        """kata_runtime_create: many streams on worker threads, every result published on ZeroMQ.
        publish: comma-separated endpoints to bind ("tcp://127.0.0.1:*" picks a free port: see
        Runtime.publish_endpoint); ingest: endpoints to read frames from ("bind:" prefix binds).
        max_frame_age_seconds: older ingest frames are dropped (0: never; default 0.25).
        direct_ingest: the ingest is fed by the app's own transport through Runtime.offer instead
        of sockets (ingest must then be None; kata_runtime_desc.direct_ingest, 1.1).
        on_stream_open(info, stream): called on the runtime's I/O thread when a skeleton definition
        opens a stream, before its first frame (kata_runtime_desc.on_stream_open, 1.1): info is a
        dict (stream_id, revision, joint_count, layout, has_rest_pose, frame_rate), stream a Stream
        valid only during the call, to attach a teacher to (Stream.attach_shared_teacher: build the
        Teacher beforehand) or set a practice section on. Returning False or raising refuses the
        stream (counted in counters()["streams_refused_by_app"]). stream_stencil: the stencil of
        those streams (a teacher needs its model's, Model.stencil).
        Arguments left None keep kata_runtime_desc_init's defaults. [any thread]"""
        from . import runtime as _runtime  # runtime.py builds on this module
        d = _n.RuntimeDesc()
        _n.runtime_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
        for field, value in (("workers", workers), ("max_streams", max_streams), ("max_joints", max_joints),
                             ("queue_capacity", queue_capacity), ("send_hwm", send_hwm),
                             ("max_message_bytes", max_message_bytes),
                             ("skeleton_resend_seconds", skeleton_resend_seconds),
                             ("max_frame_age_seconds", max_frame_age_seconds)):
            if value is not None:
                setattr(d, field, value)
        d.publish_endpoints = _utf8(publish)
        d.ingest_endpoints = _utf8(ingest)
        if ingest_pull is not None:
            d.ingest_pull = 1 if ingest_pull else 0
        d.direct_ingest = 1 if direct_ingest else 0
        if stream_stencil is not None:
            d.stream_stencil = int(stream_stencil)
        hook = _runtime._stream_open_hook(on_stream_open) if on_stream_open is not None else None
        if hook is not None:
            d.on_stream_open = ctypes.cast(hook, ctypes.c_void_p)
        r = self._make(_runtime.Runtime, "kata_runtime_create", _n.runtime_create, ctypes.byref(d))
        r._stream_open_hook = hook  # called by the runtime until it is destroyed
        return r

    def create_teacher(self, model: "Model", **teacher: Any) -> "Teacher":
        """kata_teacher_create (1.1): a teacher built once, for Stream.attach_shared_teacher; the
        arguments are Stream.attach_teacher's (clip, skeleton + positions + frame_time, features,
        joints, first_frame, pose_frame, layout, ghost, ghost_across, alignment_window, on_progress,
        tolerance, retarget options); ghost, ghost_across, alignment_window, tolerance and the retarget options are the
        defaults of the streams it is attached to. [any thread]"""
        from . import stream as _stream  # stream.py builds on this module
        args: Dict[str, Any] = {"clip": None, "skeleton": None, "positions": None, "frame_time": None, "layout": None,
                "first_frame": 0, "pose_frame": -1, "ghost": None, "features": None, "joints": None,
                "body_height": 0.0, "ghost_across": False, "alignment_window": None, "on_progress": None,
                "tolerance": None}
        retarget = {k: v for k, v in teacher.items() if k not in args}
        args.update({k: v for k, v in teacher.items() if k in args})
        d, keep = _stream._teacher_desc(model, args["clip"], args["skeleton"], args["positions"], args["frame_time"],
                                        args["layout"], args["first_frame"], args["pose_frame"], args["ghost"],
                                        args["features"], args["joints"], args["body_height"], args["ghost_across"],
                                        args["alignment_window"], args["on_progress"], retarget, args["tolerance"])
        t = self._make(Teacher, "kata_teacher_create", _n.teacher_create, ctypes.byref(d))
        del keep  # copied by the call
        return t

    def create_retargeter(self, student: "Skeleton", **options: Any) -> "Retargeter":
        """kata_retargeter_create: student is a Skeleton with rest offsets. options: joint_set ("cmu" or
        "gpd"), gradient_tolerance, max_iterations, warm_start, restore_bone_lengths."""
        from . import retarget as _retarget  # retarget.py builds on this module
        d = _retarget._retarget_desc(options)
        r = self._make(_retarget.Retargeter, "kata_retargeter_create", _n.retargeter_create, student.handle, ctypes.byref(d))
        r._student_joints = student.joint_count
        return r

    def create_retargeter_for_stream(self, stream: "Stream", **options: Any) -> "Retargeter":
        """kata_retargeter_create_for_stream: the stream's skeleton is the student."""
        from . import retarget as _retarget
        d = _retarget._retarget_desc(options)
        r = self._make(_retarget.Retargeter, "kata_retargeter_create_for_stream", _n.retargeter_create_for_stream,
                       stream.handle, ctypes.byref(d))
        r._student_joints = stream._joints
        return r



class Skeleton(_Handle):
    """An immutable joint tree (kata_skeleton)."""
    _release = _n.skeleton_destroy

    @property
    def joint_count(self) -> int:
        return _n.skeleton_joint_count(self.handle)

    @property
    def names(self) -> List[str]:
        return [_text(_n.skeleton_joint_name(self.handle, i)) or "" for i in range(self.joint_count)]

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

    @_typed
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

    @_typed
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


class Landmarks(_Handle):
    """A landmark recording (kata_landmarks, 1.1; Context.load_landmarks): frames of a built-in
    layout's joints with their capture times, e.g. a webcam teacher for Stream.attach_teacher
    (skeleton = Context.create_layout(layout), positions = .positions, frame_time = .frame_time).
    Immutable."""
    _release = _n.landmarks_destroy

    @property
    def frame_count(self) -> int:
        return _n.landmarks_frame_count(self.handle)

    @property
    def joint_count(self) -> int:
        """Joints per frame (the layout's)."""
        return _n.landmarks_joint_count(self.handle)

    @property
    def frame_time(self) -> float:
        """Seconds between frames: the timestamps' median step (the upper of the middle two for an
        even count of steps), else 1 / fps."""
        return _n.landmarks_frame_time(self.handle)

    @property
    def capture_times(self) -> np.ndarray:
        """Every frame's capture time, seconds from the first frame (kata_landmarks_capture_time)."""
        h = self.handle
        return np.array([_n.landmarks_capture_time(h, i) for i in range(_n.landmarks_frame_count(h))],
                        dtype=np.float64)

    @property
    def positions(self) -> np.ndarray:
        """Every frame's positions, (frames, joints, 3) float32 as recorded (a copy)."""
        h = self.handle
        n, j = _n.landmarks_frame_count(h), _n.landmarks_joint_count(h)
        address = _n.landmarks_positions(h)
        if not address or n == 0:
            return np.zeros((n, j, 3), dtype=np.float32)
        return np.ctypeslib.as_array(ctypes.cast(address, _n.c_float_p), shape=(n, j, 3)).copy()


class Teacher(_Handle):
    """A teacher built once and shared by any number of streams (kata_teacher, 1.1;
    Context.create_teacher, Stream.attach_shared_teacher). Streams keep it after close()."""
    _release = _n.teacher_destroy

    @property
    def frame_count(self) -> int:
        """Teacher frames the alignment follows (1 for a one-pose teacher)."""
        return _n.teacher_frame_count(self.handle)

    @property
    def frame_time(self) -> float:
        """Seconds between teacher frames (0 for a one-pose teacher)."""
        return _n.teacher_frame_time(self.handle)

    @property
    def memory_bytes(self) -> int:
        """Bytes the teacher's frames hold, once however many streams share it."""
        return _n.teacher_memory_bytes(self.handle)


class Model(_Handle):
    """A loaded, verified scoring model (kata_model); shareable by any number of streams."""
    _release = _n.model_destroy

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
