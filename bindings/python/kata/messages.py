"""Messages: a subscriber of a runtime's (or `kata serve`'s) results, decoded by the C library's
verifier (kata_message_read_result); and the messages a source sends to a runtime's ingest, written
by the C library's writers (kata_message_write_*, since 1.1)."""
import ctypes
import time
from typing import Any, Callable, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from . import _native as _n
from ._util import _address, _positions_f32, _typed, _utf8
from .errors import KataError, Status

__all__ = ["Subscriber", "ResultMessage", "PracticeSection", "read_message", "write_skeleton", "write_frame",
           "write_practice"]


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
    """One result message (a kata_result_record) as Python values: stream_id, result_sequence,
    frame_sequence, frame_index, capture_time (seconds, source clock), arrival_ns / computed_ns /
    published_ns (CLOCK_MONOTONIC ns on the runtime's host), scored, matched_teacher_frame,
    matched_teacher_time (seconds from the teacher's first frame, -1 unless scored), distance
    (dimensionless), score (0..100), parts (split of d^2), part_scores, part_to_fix (BodyPart or
    -1), state (ScoreState), ghost ((G, 3) float32 copy, or None), practice (the PracticeSection it
    was computed under; None without a clip teacher or from an older runtime), and the correction
    cue (present iff part_to_fix >= 0): cue_joint (the GPD joint to move, e.g. "LKnee"; "" for
    none), cue_degrees (the angle at it, degrees; 0 for none), cue_action (CueAction or -1) and
    cue (the phrase, "left knee: bend 30 deg more"; "" for none)."""
    __slots__ = ("stream_id", "result_sequence", "frame_sequence", "frame_index", "capture_time", "arrival_ns",
                 "computed_ns", "published_ns", "scored", "matched_teacher_frame", "matched_teacher_time",
                 "distance", "score", "parts", "part_scores", "part_to_fix", "state", "ghost", "practice",
                 "cue_joint", "cue_degrees", "cue_action", "cue")
    stream_id: int
    result_sequence: int
    frame_sequence: int
    frame_index: int
    capture_time: float
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
    cue_joint: str
    cue_degrees: float
    cue_action: int
    cue: str

    def __init__(self, m: "_n.ResultRecord") -> None:
        for name in ("stream_id", "result_sequence", "frame_sequence", "frame_index", "capture_time", "arrival_ns",
                     "computed_ns", "published_ns", "matched_teacher_frame", "matched_teacher_time", "distance",
                     "score", "part_to_fix", "state"):
            setattr(self, name, getattr(m, name))
        self.practice = (PracticeSection(m.practice_start_time, m.practice_end_time, bool(m.practice_loop),
                                         m.practice_revision) if m.has_practice else None)
        self.scored = bool(m.scored)
        self.parts = tuple(m.parts)
        self.part_scores = tuple(m.part_scores)
        _set_cue(self, m)
        # The C ghost pointer is valid only until this thread's next call: copied now.
        self.ghost = (np.ctypeslib.as_array(ctypes.cast(m.ghost, ctypes.POINTER(ctypes.c_float)),
                                            shape=(m.ghost_joint_count, 3)).copy()
                      if m.ghost_joint_count and m.ghost else None)

    def __repr__(self) -> str:
        return "ResultMessage(stream=%d, seq=%d, score=%.2f)" % (self.stream_id, self.result_sequence, self.score)




def _set_cue(out: Any, rec: "_n.ResultRecord") -> None:
    """The cue fields of a Python result from its record (ResultMessage, stream.ScoreRecord)."""
    name = _n.gpd_joint_name(rec.cue_joint) if rec.cue_joint >= 0 else None
    out.cue_joint = name.decode() if name else ""
    out.cue_degrees = float(rec.cue_degrees) if name else 0.0
    out.cue_action = int(rec.cue_action) if name else -1
    out.cue = _n.cue_phrase(rec) if name else ""


def read_message(message: bytes) -> Optional[ResultMessage]:
    """kata_message_read_result: one ZeroMQ message of a kata runtime (16-byte topic + FlatBuffer),
    checked by the FlatBuffers verifier. A ResultMessage; None for a valid message that is not a
    result (a skeleton definition, stats, a practice setting); KataError E_PARSE for a refused one (truncated, corrupt).
    [any thread]"""
    m = _n.ResultRecord()
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
    Valid non-result messages (skeleton definitions, stats, practice settings) and refused messages are counted (skipped, refused), never returned.

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
        self.skipped = 0  #: valid messages that are not results (skeleton definitions, stats, practice settings)
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


# ---- writing ingest messages (kata/runtime.h "Writing ingest messages") --------------------------

def _write(write: Callable[..., int], message: Any, call: str) -> bytes:
    """One writer call: the size, then the bytes (16-byte topic + FlatBuffer)."""
    size = ctypes.c_size_t(0)
    status = write(ctypes.byref(message), None, 0, ctypes.byref(size))
    if status == Status.E_BUFFER_TOO_SMALL:
        buffer = ctypes.create_string_buffer(size.value)
        status = write(ctypes.byref(message), buffer, size.value, ctypes.byref(size))
        if status == Status.OK:
            return buffer.raw[:size.value]
    raise KataError(status, (_n.context_last_error(None) or b"").decode(), call)


@_typed
def write_skeleton(stream_id: int, skeleton: Any, layout: Optional[str] = None,
                   name_map: Optional[Sequence[str]] = None, revision: int = 1, up_axis: int = 0,
                   metres_per_unit: float = 0.0, frame_rate: float = 0.0, closed: bool = False) -> bytes:
    """kata_message_write_skeleton: a stream's skeleton definition message (send it first and again
    every second or so). skeleton: a Skeleton; layout: a built-in layout's name, or name_map: the
    16 joint names read as the GPD joints (one of the two); up_axis: UpAxis.Y or UpAxis.Z;
    metres_per_unit, frame_rate: 0 unknown; closed: the source ends the stream. KataError on a
    refusal. [any thread]"""
    m = _n.SkeletonMessage()
    _n.skeleton_message_init_sized(ctypes.byref(m), ctypes.sizeof(m))
    m.stream_id, m.revision, m.skeleton = stream_id, revision, skeleton.handle
    m.layout = _utf8(layout)
    names = None
    if name_map is not None:
        names = (ctypes.c_char_p * len(name_map))(*[_utf8(n) for n in name_map])
        if len(name_map) != 16:
            raise ValueError("name_map holds the 16 GPD joints' names, not %d" % len(name_map))
        m.name_map = ctypes.cast(names, ctypes.POINTER(ctypes.c_char_p))
    m.up_axis, m.metres_per_unit, m.frame_rate, m.closed = int(up_axis), metres_per_unit, frame_rate, int(bool(closed))
    return _write(_n.message_write_skeleton, m, "kata_message_write_skeleton")


@_typed
def write_frame(stream_id: int, sequence: int, capture_time: float, positions: Any,
                confidences: Any = None) -> bytes:
    """kata_message_write_frame: one frame message. positions: (joints, 3) floats in the skeleton
    definition's joint order and units, all finite; confidences: joints floats in [0, 1] (NaN:
    missing), or None; capture_time: seconds on the source's clock. KataError on a refusal
    (E_NON_FINITE for a NaN or infinite coordinate). [any thread]"""
    p = _positions_f32(positions)
    if p.size % 3:
        raise ValueError("positions hold joints x 3 floats, not %d floats" % p.size)
    m = _n.FrameMessage()
    _n.frame_message_init_sized(ctypes.byref(m), ctypes.sizeof(m))
    m.stream_id, m.sequence, m.capture_time = stream_id, sequence, capture_time
    m.joint_count = p.size // 3
    m.positions = _address(p) if p.size else None
    c = None
    if confidences is not None:
        c = np.ascontiguousarray(confidences, dtype=np.float32)
        if c.size != m.joint_count:
            raise ValueError("confidences hold one float per joint (%d), not %d" % (m.joint_count, c.size))
        m.confidences = _address(c)
    return _write(_n.message_write_frame, m, "kata_message_write_frame")


@_typed
def write_practice(stream_id: int, revision: int = 1, teacher_start: float = 0.0,
                   loop: Optional[Tuple[float, float]] = None) -> bytes:
    """kata_message_write_practice: a stream's practice setting message (Runtime.set_practice, sent
    by the stream's source): the lesson from teacher_start seconds, or loop = (start, end) seconds
    looped; revision: 1 and up, a new one per change. KataError (E_INVALID_ARGUMENT) for what no
    clip allows. [any thread]"""
    m = _n.PracticeMessage()
    _n.practice_message_init_sized(ctypes.byref(m), ctypes.sizeof(m))
    m.stream_id, m.revision, m.teacher_start = stream_id, revision, teacher_start
    if loop is not None:
        m.loop, m.loop_start, m.loop_end = 1, loop[0], loop[1]
    return _write(_n.message_write_practice, m, "kata_message_write_practice")
