"""Messages: a subscriber of a runtime's (or `kata serve`'s) results, decoded by the C library's
verifier (kata_message_read_result)."""
import ctypes
import time
from typing import Any, NamedTuple, Optional

import numpy as np

from . import _native as _n
from .errors import KataError, Status

__all__ = ["Subscriber", "ResultMessage", "PracticeSection", "read_message"]


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
