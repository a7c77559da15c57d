"""A live pose stream (kata_stream): frames in, features, scores and ghosts out, and the numpy
records results are read into."""
import ctypes
import warnings
from typing import Any, Callable, Dict, List, NoReturn, Optional, Sequence, Tuple

import numpy as np

from . import _native as _n
from ._util import _address, _positions_f32, _text, _time_units_code, _type_error, _typed, _utf8
from .errors import KataError, ResultsDroppedError, ResultsDroppedWarning, Status
from .objects import GPD_DIMS, GPD_JOINTS, Clip, Model, Skeleton, Teacher, _Handle
from .retarget import _retarget_desc

__all__ = ["Stream", "ResultBuffer", "Results", "ScoreRecord", "cue_text", "gpd_joint_name", "gpd_joint_part", "body_part_name", "gpd_joint_words", "detect_time_units", "RESULT_DTYPE", "DROP_POLICIES"]

#: What read_results does when results were overwritten unread since the previous read (a full
#: ring): "warn" (ResultsDroppedWarning, the default), "raise" (ResultsDroppedError carrying the
#: results that were read), "count" (only Results.dropped says so).
DROP_POLICIES = ("warn", "raise", "count")

#: numpy dtype with the exact layout of kata_result_record (read into directly).
RESULT_DTYPE = np.dtype(_n.ResultRecord)
assert RESULT_DTYPE.itemsize == ctypes.sizeof(_n.ResultRecord)


def cue_text(record: Any) -> str:
    """The correction cue of a result (kata_cue_text): "left knee: bend 30 deg more", "" without
    one. record: a RESULT_DTYPE row (e.g. of Stream.read_results' array) or a ResultRecord."""
    if not isinstance(record, _n.ResultRecord):
        record = _n.ResultRecord.from_buffer_copy(np.asarray(record, dtype=RESULT_DTYPE).tobytes())
    return _n.cue_phrase(record)


def gpd_joint_name(joint: int) -> str:
    """The GPD joint name of joint 0..15 ("LKnee"; kata_gpd_joint_name), e.g. of a result's
    cue_joint; "" out of range."""
    name = _n.gpd_joint_name(int(joint))
    return name.decode("utf-8", "replace") if name else ""


def gpd_joint_part(joint: int) -> int:
    """The BodyPart GPD joint 0..15 belongs to (kata_gpd_joint_part, 1.1; kata/result.h lists each
    part's joints), -1 out of range."""
    return int(_n.gpd_joint_part(int(joint)))


def body_part_name(part: int) -> str:
    """The short name of a BodyPart ("torso_head", "left_arm", "right_arm", "left_leg",
    "right_leg"; kata_body_part_name, 1.1), e.g. of a result's part_to_fix; "" out of range."""
    name = _n.body_part_name(int(part))
    return name.decode("utf-8", "replace") if name else ""


def gpd_joint_words(joint: int) -> str:
    """GPD joint 0..15 in the words cue_text starts its phrase with ("left knee", "lower back";
    kata_gpd_joint_words, 1.1); "" for the five end joints, which no cue names, and out of range."""
    words = _n.gpd_joint_words(int(joint))
    return words.decode("utf-8", "replace") if words else ""


def detect_time_units(timestamps: Any) -> str:
    """kata_time_units_detect: "s" or "ms" for recorded timestamps (n >= 2, increasing) from the
    median step between frames (2..1000 Hz is plausible); raises KataError when it fits neither."""
    ts = np.ascontiguousarray(timestamps, dtype=np.float64)
    out = ctypes.c_int(0)
    status = _n.time_units_detect(ts.ctypes.data, ts.size, ctypes.byref(out))
    if status:
        raise KataError(status, _text(_n.context_last_error(None)), "kata_time_units_detect")
    return "ms" if out.value == 1 else "s"


class ScoreRecord:
    """One scored frame (a kata_result_record), as plain Python values."""
    __slots__ = ("matched_teacher_frame", "matched_teacher_time", "frame_index", "capture_time", "distance", "score",
                 "parts", "part_scores", "part_to_fix", "state", "cue_joint", "cue_degrees", "cue_action", "cue",
                 "repetition", "repetition_progress")

    def __init__(self, rec: "_n.ResultRecord") -> None:
        self.matched_teacher_frame = rec.matched_teacher_frame
        self.matched_teacher_time = rec.matched_teacher_time
        self.frame_index = rec.frame_index
        self.capture_time = rec.capture_time
        self.distance = rec.distance
        self.score = rec.score
        self.parts = tuple(rec.parts)
        self.part_scores = tuple(rec.part_scores)
        self.part_to_fix = rec.part_to_fix
        self.state = rec.state
        # The correction cue (messages.ResultMessage says what each field holds).
        from .messages import _set_cue
        _set_cue(self, rec)
        # 1.1: the repetition in progress (1 + the complete ones; 0 without a clip teacher) and the
        # progress through the teacher's section, 0..1.
        self.repetition = int(rec.repetition)
        self.repetition_progress = float(rec.repetition_progress)

    def __repr__(self) -> str:
        return "ScoreRecord(frame=%d, score=%.2f, distance=%.5g)" % (self.frame_index, self.score, self.distance)


class ResultBuffer:
    """Preallocated arrays that Stream.read_results fills in place (no allocation per read):
    results (capacity,) RESULT_DTYPE (scores: the same array, each record carries its score), ghosts (capacity, G, 3)
    float32 where G = the stream's ghost joint count, features (capacity, 1683) float32 when
    with_features. The views a read returns stay valid until the next read into this buffer."""

    def __init__(self, capacity: int, ghost_joints: int = 0, with_scores: bool = True,
                 with_features: bool = False) -> None:
        self.capacity = int(capacity)
        self.results = np.zeros(self.capacity, dtype=RESULT_DTYPE)
        self.results["struct_size"] = RESULT_DTYPE.itemsize
        # One record per result holds its score too: scores is the same array (with_scores is kept
        # so callers of 0.x need no change; None when they asked for none).
        self.scores: Optional[np.ndarray] = self.results if with_scores else None
        self.ghosts = np.zeros((self.capacity, ghost_joints, 3), dtype=np.float32) if ghost_joints else None
        self.features = np.zeros((self.capacity, GPD_DIMS), dtype=np.float32) if with_features else None
        # The C call's arguments, computed once.
        self._args = (_address(self.results), None if self.ghosts is None else _address(self.ghosts),
                      0 if self.ghosts is None else self.ghosts.size,
                      None if self.features is None else _address(self.features),
                      0 if self.features is None else self.features.size, self.capacity)
        self._count = ctypes.c_uint32()
        self._count_ref = ctypes.byref(self._count)


class Results:
    """What one read moved: numpy arrays (results, scores, ghosts, features; None when not
    requested), `len()` results long, and dropped: the results overwritten unread (a full ring)
    since the previous read, lost before this one (0 when nothing was lost). From a ResultBuffer
    the arrays are views valid until the next read into it; from push_and_read they are owned."""
    __slots__ = ("results", "scores", "ghosts", "features", "dropped")

    def __init__(self, buf: ResultBuffer, n: int, dropped: int = 0) -> None:
        self.results: np.ndarray = buf.results[:n]
        self.scores: Optional[np.ndarray] = None if buf.scores is None else buf.scores[:n]
        self.ghosts: Optional[np.ndarray] = None if buf.ghosts is None else buf.ghosts[:n]
        self.features: Optional[np.ndarray] = None if buf.features is None else buf.features[:n]
        self.dropped = dropped

    @staticmethod
    def concatenate(parts: Sequence["Results"]) -> "Results":
        """One Results owning copies of every part's arrays, in order (dropped: their sum)."""
        out = Results.__new__(Results)
        out.results, out.scores, out.ghosts, out.features = np.zeros(0, dtype=RESULT_DTYPE), None, None, None
        out.dropped = sum(p.dropped for p in parts)
        for name in ("results", "scores", "ghosts", "features"):
            arrays = [getattr(p, name) for p in parts if getattr(p, name) is not None]
            if arrays:
                setattr(out, name, np.concatenate(arrays))
        return out

    def __len__(self) -> int:
        return len(self.results)

    def __repr__(self) -> str:
        return "Results(%d results%s)" % (len(self), ", %d dropped before them" % self.dropped if self.dropped else "")


def _tolerance_text(tolerance: Any) -> Optional[bytes]:
    """kata_teacher_desc.tolerance of "strict", "normal", "lenient" or a number of degrees; None: the default."""
    if tolerance is None:
        return None
    if isinstance(tolerance, bool) or not isinstance(tolerance, (str, int, float)):
        raise TypeError("tolerance must be 'strict', 'normal', 'lenient' or a number of degrees, not %r" % (tolerance,))
    return (tolerance if isinstance(tolerance, str) else "%.9g" % float(tolerance)).encode("utf-8")


def _teacher_desc(model: Any, clip: Any, skeleton: Any, positions: Any, frame_time: Optional[float],
                  layout: Optional[str], first_frame: int, pose_frame: int, ghost: Optional[bool], features: Any,
                  joints: Any, body_height: float, ghost_across: bool, alignment_window: Optional[float],
                  on_progress: Optional[Callable[[int, int], None]], retarget: Dict[str, Any],
                  tolerance: Any = None) -> Tuple[Any, List[Any]]:
    """A kata_teacher_desc from Stream.attach_teacher's arguments, and what must outlive the C call
    that reads it (arrays, the progress callback, the retarget desc)."""
    d = _n.TeacherDesc()
    _n.teacher_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
    d.model = model.handle
    keep: List[Any] = []
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
    d.layout = _utf8(layout)
    d.first_frame = first_frame
    d.pose_frame = pose_frame
    if ghost is None:
        ghost = features is None and joints is None
    d.ghost = 1 if ghost else 0
    d.ghost_across = 1 if ghost_across else 0
    if alignment_window is not None:
        d.alignment_window = alignment_window
    d.tolerance = _tolerance_text(tolerance)
    if on_progress is not None:
        progress = on_progress

        def _progress(user: Optional[int], done: int, frames: int) -> None:
            progress(int(done), int(frames))
        d.on_progress = _n.ProgressCallback(_progress)
        keep.append(d.on_progress)
    rdesc = _retarget_desc(retarget) if retarget else None
    if rdesc is not None:
        d.retarget = ctypes.pointer(rdesc)
        keep.append(rdesc)
    return d, keep


class Stream(_Handle):
    """A live pose stream (kata_stream): frames in, features / scores / ghosts out. Used by one
    thread at a time (kata.h)."""
    _release = _n.stream_destroy
    _joints = 0
    _result_capacity = 64  # set by Context.open_stream from the descriptor
    _dropped_seen = 0      # results_dropped at the previous read
    _first_time: Optional[float] = None  # the first frame's timestamp, until the first step is checked
    _units_checked = False  # the first step between frames was checked as seconds (_check_seconds)
    _on_drop = "warn"

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
        nothing; a first step between frames that fits milliseconds only (1..500, above 5 s) raises
        ValueError (as the landmark path checks stated seconds). Does not allocate in C. [stream
        owner: one thread at a time]"""
        a = positions
        if type(a) is not np.ndarray or a.dtype != np.float32 or not a.flags.c_contiguous:
            a = _positions_f32(a)
        if not self._units_checked:
            self._check_seconds(timestamp)
        try:  # free unless raised (3.11): a wrong timestamp type is a TypeError naming it, not ctypes'
            if confidences is None:
                status = _n.stream_push(self.handle, timestamp, _address(a), a.size // 3)
            else:
                c = confidences
                if type(c) is not np.ndarray or c.dtype != np.float32 or not c.flags.c_contiguous:
                    c = np.ascontiguousarray(c, dtype=np.float32)
                if c.size * 3 != a.size:
                    raise ValueError("confidences: one per joint (%d), got %d" % (a.size // 3, c.size))
                status = _n.stream_push_confidence(self.handle, timestamp, _address(a), _address(c), a.size // 3)
        except ctypes.ArgumentError as e:
            raise _type_error(Stream.push, (self, timestamp, positions, confidences), {}, e) from None
        if status and status != Status.TRACKING_LOST:
            self._raise(status, "kata_stream_push_confidence" if confidences is not None else "kata_stream_push")
        if not self._units_checked:
            self._note_times([timestamp])
        return Status(status)

    def _check_seconds(self, timestamps: Any) -> None:
        """The landmark path's check of stated seconds (kata_time_units_detect's ranges) on the
        stream's first steps: a median step that fits milliseconds only (1..500, above the 5 s a
        slow webcam page makes) raises ValueError before anything is pushed. Only the first step
        is checked, so a later pause is never taken for a unit slip."""
        try:
            t = np.atleast_1d(np.asarray(timestamps, dtype=np.float64))
        except (TypeError, ValueError):
            return  # the push itself names a wrong type
        if self._first_time is not None:
            t = np.concatenate((np.array([self._first_time], dtype=np.float64), t))
        if len(t) < 2:
            return
        step = float(np.median(np.diff(t)))
        if 1.0 <= step <= 500.0 and not step <= 5.0:
            raise ValueError("timestamps: the step between frames is %.6g: %.4g Hz if milliseconds, a frame every "
                             "%.4g s if seconds; Stream.push takes seconds: divide milliseconds (MediaPipe's) by "
                             "1000, or push them with push_many(..., time_units=\"ms\")"
                             % (step, 1000.0 / step, step))

    def _note_times(self, timestamps: Any) -> None:
        t = np.atleast_1d(np.asarray(timestamps, dtype=np.float64))
        if self._first_time is None and len(t) == 1:
            self._first_time = float(t[0])
        elif len(t):
            self._units_checked = True

    def push_landmarks(self, timestamp: float, values: Any, time_units: str = "s") -> Status:
        """kata_stream_push_landmarks: one frame in a landmark source's own shape, values
        (joints, 3|4|5) float32: x y z [confidence | MediaPipe's visibility presence, read as
        confidence = the smaller]; timestamp in time_units "s" or "ms"."""
        a = np.ascontiguousarray(values, dtype=np.float32)
        if a.ndim != 2 or a.shape[0] != self._joints or a.shape[1] not in (3, 4, 5):
            raise ValueError("values must be (%d joints, 3, 4 or 5 channels)" % self._joints)
        try:
            status = _n.stream_push_landmarks(self.handle, timestamp, _time_units_code(time_units), _address(a),
                                              a.shape[0], a.shape[1])
        except ctypes.ArgumentError as e:
            raise _type_error(Stream.push_landmarks, (self, timestamp, values, time_units), {}, e) from None
        if status not in (0, Status.TRACKING_LOST):
            self._raise(status, "kata_stream_push_landmarks")
        return Status(status)

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
        if not self._units_checked:
            self._check_seconds(ts)
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
        if not self._units_checked:
            self._note_times(ts)
        return lost.value

    @_typed
    def set_confidence_gate(self, threshold: float = 0.5, max_hold: float = 0.5,
                            max_missing_share: float = 0.25) -> None:
        """kata_stream_set_confidence_gate: a GPD joint below `threshold` (or NaN) is missing and
        held at its last good position for at most `max_hold` seconds; more than
        max_missing_share x 16 joints missing (or one missing longer) is TRACKING_LOST. Takes effect
        at the next push. [stream owner]"""
        status = _n.stream_set_confidence_gate(self.handle, threshold, max_hold, max_missing_share)
        if status:
            self._raise(status, "kata_stream_set_confidence_gate")

    @_typed
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

    def _push_many_landmarks(self, timestamps: Any, values: Any, time_units: str) -> int:
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

    def features(self, out: Optional[np.ndarray] = None) -> Optional[Tuple[np.ndarray, float, int]]:
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
    @_typed
    def attach_teacher(self, model: Model, clip: Optional[Clip] = None, skeleton: Optional[Skeleton] = None,
                       positions: Any = None, frame_time: Optional[float] = None, layout: Optional[str] = None,
                       first_frame: int = 0, pose_frame: int = -1, ghost: Optional[bool] = None, features: Any = None,
                       joints: Any = None, body_height: float = 0.0, ghost_across: bool = False,
                       alignment_window: Optional[float] = None,
                       on_progress: Optional[Callable[[int, int], None]] = None, tolerance: Any = None,
                       **retarget: Any) -> None:
        """kata_stream_attach_teacher: score against (and ghost from) a teacher given as one of
        a Clip; a Skeleton + positions (frames, joints, 3) + frame_time; GPD features
        (frames, 1683) + frame_time; or joints, one held pose of the 16 GPD joints (16, 3) with its
        body_height. pose_frame >= first_frame: that frame only, as a single pose. ghost: default
        True for a clip or positions (features and joints have none to make). retarget: the ghost
        solver's options (joint_set "cmu"/"gpd", gradient_tolerance, max_iterations, warm_start,
        restore_bone_lengths). ghost_across: the ghost across layouts (a CMU clip teacher, a
        MediaPipe student): 16 GPD joints in the student's axes and units, once the stream has
        measured the student's bones (kata_teacher_desc.ghost_across, 1.1). alignment_window: the
        seconds of teacher ahead of the last match the alignment looks in ((0, 60]; None: 0.5, a clip
        teacher only; 1.1). on_progress(done, frames): called on this thread as the teacher's
        features are computed, done == frames on the last call (a long teacher's loading; not for
        features or joints; 1.1); an exception it raises is printed and ignored (ctypes). tolerance:
        the lesson's, "strict", "normal" (None: the default), "lenient" or the angle in degrees
        (5..120) at which a part scores 50 (kata_teacher_desc.tolerance, 1.1)."""
        d, keep = _teacher_desc(model, clip, skeleton, positions, frame_time, layout, first_frame, pose_frame, ghost,
                                features, joints, body_height, ghost_across, alignment_window, on_progress, retarget,
                                tolerance)
        status = _n.stream_attach_teacher(self.handle, ctypes.byref(d))
        del keep  # copied by the call
        if status:
            self._raise(status, "kata_stream_attach_teacher")

    @_typed
    def attach_shared_teacher(self, teacher: Teacher, ghost: Optional[bool] = None, ghost_across: Optional[bool] = None,
                              alignment_window: Optional[float] = None, tolerance: Any = None,
                              **retarget: Any) -> None:
        """kata_stream_attach_shared_teacher (1.1): score against a Teacher built once
        (Context.create_teacher) without copying it; results are those attach_teacher gives with
        the same arguments. With no argument the stream takes the per-stream options the teacher
        was created with; any of ghost, ghost_across, alignment_window, tolerance or retarget options given
        replaces them all for this stream (the others at their defaults: ghost True, which a
        teacher given as features or joints refuses). A practice section: set_practice_section
        afterwards."""
        options = None
        if ghost is not None or ghost_across is not None or alignment_window is not None or tolerance is not None \
                or retarget:
            d = _n.TeacherDesc()
            _n.teacher_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
            if ghost is not None:
                d.ghost = 1 if ghost else 0
            d.ghost_across = 1 if ghost_across else 0
            if alignment_window is not None:
                d.alignment_window = alignment_window
            d.tolerance = _tolerance_text(tolerance)
            rdesc = _retarget_desc(retarget) if retarget else None
            if rdesc is not None:
                d.retarget = ctypes.pointer(rdesc)
            options = ctypes.byref(d)
        status = _n.stream_attach_shared_teacher(self.handle, teacher.handle, options)
        if status:
            self._raise(status, "kata_stream_attach_shared_teacher")

    def detach_teacher(self) -> None:
        """kata_stream_detach_teacher: later results are not scored and carry no ghost."""
        status = _n.stream_detach_teacher(self.handle)
        if status:
            self._raise(status, "kata_stream_detach_teacher")

    def set_practice_section(self, first_frame: int, last_frame: int = -1, loop: bool = False) -> None:
        """kata_stream_set_practice_section: from the next frame follow only the teacher's frames
        first_frame..last_frame (0-based from the teacher's first frame; -1: its end), looped when
        loop (a section practised over and over, and the repetition read_repetitions counts)."""
        status = _n.stream_set_practice_section(self.handle, int(first_frame), int(last_frame), 1 if loop else 0)
        if status:
            self._raise(status, "kata_stream_set_practice_section")

    def restart_teacher(self) -> None:
        """kata_stream_restart_teacher: the next frame is matched from the teacher's first frame."""
        status = _n.stream_restart_teacher(self.handle)
        if status:
            self._raise(status, "kata_stream_restart_teacher")

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
    def gpd_joint_sources(self) -> np.ndarray:
        """The stream skeleton's joint read as each of the 16 GPD joints (GPD order,
        gpd_joint_name), -1 for one the layout synthesises from several joints ("mediapipe"'s Hip,
        Chest, Neck, Head) (kata_stream_gpd_joint_source, 1.1)."""
        h = self.handle
        return np.array([_n.stream_gpd_joint_source(h, i) for i in range(GPD_JOINTS)], dtype=np.int32)

    @property
    def results_pending(self) -> int:
        """Unread results in the ring (kata_stream_results_pending). [stream owner]"""
        return int(_n.stream_results_pending(self.handle))

    @property
    def results_dropped(self) -> int:
        """Results overwritten unread since the stream was opened (kata_stream_results_dropped)."""
        return int(_n.stream_results_dropped(self.handle))

    @property
    def result_capacity(self) -> int:
        """Results the ring keeps until read (open_stream's result_capacity)."""
        return self._result_capacity

    @property
    def on_drop(self) -> str:
        """What a read does when results were lost since the previous read: "warn" (the default),
        "raise" or "count" (DROP_POLICIES). Settable."""
        return self._on_drop

    @on_drop.setter
    def on_drop(self, policy: str) -> None:
        if policy not in DROP_POLICIES:
            raise ValueError("on_drop must be one of %s, not %r" % (", ".join(DROP_POLICIES), policy))
        self._on_drop = policy

    def result_buffer(self, capacity: Optional[int] = None, scores: bool = True, ghosts: bool = True,
                      features: bool = False) -> ResultBuffer:
        """A ResultBuffer sized for this stream (capacity default: every result the ring can hold)."""
        if capacity is None:
            capacity = max(self.results_pending, self._result_capacity)
        return ResultBuffer(capacity, self.ghost_joint_count if ghosts else 0, scores, features)

    def _report_drops(self, results: Results, total: int) -> Results:
        """Results were overwritten since the previous read (total: the stream's count now): sets
        results.dropped and applies the on_drop policy, after the read, so nothing read is lost."""
        dropped, self._dropped_seen = total - self._dropped_seen, total
        results.dropped = dropped
        if self._on_drop != "count":
            message = ("kata: %d result%s overwritten unread before this read (the ring holds %d): read more often, "
                       "open the stream with a larger result_capacity, or push a recording with push_and_read"
                       % (dropped, "s were" if dropped > 1 else " was", self._result_capacity))
            if self._on_drop == "raise":
                raise ResultsDroppedError(dropped, message, results)
            warnings.warn(ResultsDroppedWarning(dropped, message), stacklevel=3)
        return results

    def read_results(self, buffer: Optional[ResultBuffer] = None, features: bool = False) -> Results:
        """kata_stream_read_results: moves every unread result (oldest first, at most the buffer's
        capacity) into numpy arrays and returns them as Results. Without a buffer, fresh arrays
        sized for what is pending are made (features only when asked and the stream keeps them).
        Results.dropped counts the results overwritten unread since the previous read; when it is
        not 0, on_drop says what happens (a ResultsDroppedWarning by default). [stream owner]"""
        if buffer is None:
            buffer = ResultBuffer(max(_n.stream_results_pending(self.handle), 1), self.ghost_joint_count, True,
                                  features)
        status = _n.stream_read_results(self.handle, *buffer._args, buffer._count_ref)
        if status:
            self._raise(status, "kata_stream_read_results")
        r = Results(buffer, buffer._count.value)
        total = _n.stream_results_dropped(self._h)  # one C call per read: drops never go unseen
        return r if total == self._dropped_seen else self._report_drops(r, total)

    def push_and_read(self, timestamps: Any, positions: Any, confidences: Any = None, time_units: Optional[str] = None,
                      features: bool = False) -> Results:
        """A recording in, every result out: push_many in chunks that fit the free room of the
        result ring, each followed by a read, so no result is overwritten whatever the length.
        Arguments as push_many; returns one Results owning its arrays (ghosts when the teacher
        makes them, features when asked and the stream keeps them). [stream owner]"""
        ts = np.asarray(timestamps, dtype=np.float64)
        if ts.ndim != 1:
            raise ValueError("timestamps must be one per frame (n,), got shape %s" % (ts.shape,))
        values = np.asarray(positions, dtype=np.float32)
        if len(values) != len(ts):
            raise ValueError("positions: one frame per timestamp (%d), got %d" % (len(ts), len(values)))
        conf = None if confidences is None else np.asarray(confidences, dtype=np.float32)
        if time_units == "auto" and len(ts) >= 2:
            time_units = detect_time_units(ts)  # once for the whole recording, not per chunk
        buffer = ResultBuffer(self._result_capacity, self.ghost_joint_count, True, features)
        parts: List[Results] = [Results.concatenate([self.read_results(buffer)])]
        start = 0
        while start < len(ts):
            room = self._result_capacity - self.results_pending
            end = min(len(ts), start + max(room, 1))
            self.push_many(ts[start:end], values[start:end], None if conf is None else conf[start:end],
                           time_units=time_units)
            parts.append(Results.concatenate([self.read_results(buffer)]))
            start = end
        return Results.concatenate(parts)

    def read_repetitions(self) -> List[Any]:
        """kata_stream_read_repetitions (1.1): the repetitions of the teacher's section that ended
        since the last call, oldest first (messages.Repetition each; docs/coach/repetitions.md). The
        stream keeps the newest 16: read at least that often."""
        from .messages import Repetition
        buf = (_n.Repetition * 16)()
        buf[0].struct_size = ctypes.sizeof(_n.Repetition)
        count = ctypes.c_uint32(0)
        out: List[Any] = []
        while True:
            status = _n.stream_read_repetitions(self.handle, buf, 16, ctypes.byref(count))
            if status:
                self._raise(status, "kata_stream_read_repetitions")
            out.extend(Repetition(buf[i]) for i in range(count.value))
            if count.value < 16:
                return out

    def read_newest(self, buffer: Optional[ResultBuffer] = None) -> Optional[Results]:
        """kata_stream_read_newest: the newest unread result (older unread ones are passed over) as
        a Results of length 1, or None when nothing is unread. buffer: a result_buffer(1) to reuse
        (no allocation per call)."""
        if buffer is None:
            buffer = ResultBuffer(1, self.ghost_joint_count, True, False)
        a = buffer._args
        status = _n.stream_read_newest(self.handle, a[0], a[1], a[2], a[3], a[4])
        if status == Status.NO_DATA:
            return None
        if status:
            self._raise(status, "kata_stream_read_newest")
        # Older unread results passed over are not drops (kata.h); overwritten ones are.
        r = Results(buffer, 1)
        total = _n.stream_results_dropped(self._h)
        return r if total == self._dropped_seen else self._report_drops(r, total)
