"""Several people in one picture (kata_people, kata/people.h): which stream each unlabeled pose
of a multi-person detector belongs to.

    with kata.Context() as ctx, kata.People(ctx, joint_count=33, max_people=4) as people:
        ids = people.track(t, poses, confidences)   # poses (n, 33, 3), any order -> ids (n,)
        people.opened_streams, people.closed_streams  # streams this frame opened and closed

An id is a person's stream (0: the pose was refused, see counters()); ids count up from 1 and are
not reused. kata/people.h explains the cost, the gate and what identity rests on.
"""
import ctypes
from typing import Any, Dict, List, NoReturn, Optional

import numpy as np

from . import _native as _n
from ._util import _text
from .errors import KataError, Status
from .objects import Context, _Handle

__all__ = ["People", "write_people_frame", "people_stream_id"]

_OPTIONS = ("max_people", "max_poses", "forget_seconds", "coast_seconds", "gate", "gate_growth", "size_gate",
            "shape_weight", "min_confidence")


class People(_Handle):
    """A people tracker (kata_people); one thread at a time. options: the fields of
    kata_people_desc (max_people, max_poses, forget_seconds, coast_seconds, gate, gate_growth,
    size_gate, shape_weight, min_confidence)."""
    _release = _n.people_destroy

    def __init__(self, context: Context, joint_count: int, **options: Any) -> None:
        d = _n.PeopleDesc()
        _n.people_desc_init_sized(ctypes.byref(d), ctypes.sizeof(d))
        d.joint_count = int(joint_count)
        for key, value in options.items():
            if key not in _OPTIONS:
                raise TypeError("unknown people option %r" % key)
            setattr(d, key, int(value) if key in ("max_people", "max_poses") else float(value))
        h = ctypes.c_void_p()
        context._check(_n.people_create(context.handle, ctypes.byref(d), ctypes.byref(h)), "kata_people_create")
        super().__init__(h.value, context)
        self.joint_count = int(joint_count)
        self._ids = np.zeros(0, dtype=np.uint32)
        self._list = np.zeros(64, dtype=np.uint32)

    def _raise(self, status: int, call: str) -> NoReturn:
        raise KataError(status, _text(_n.people_last_error(self._h)), call)

    def track(self, time: float, poses: Any, confidences: Optional[Any] = None) -> np.ndarray:
        """kata_people_track: one frame's poses, (n, joint_count, 3) in any order (n may be 0),
        confidences (n, joint_count) in [0, 1] or None -> each pose's stream id, (n,) uint32
        (0: refused)."""
        p = np.ascontiguousarray(poses, dtype=np.float32)
        if p.size % (3 * self.joint_count):
            raise ValueError("poses must be (n, %d, 3) floats, got shape %s" % (self.joint_count, p.shape))
        n = p.size // (3 * self.joint_count)
        c = None
        if confidences is not None:
            c = np.ascontiguousarray(confidences, dtype=np.float32)
            if c.size != n * self.joint_count:
                raise ValueError("confidences must be (%d, %d), got shape %s" % (n, self.joint_count, c.shape))
        ids = np.zeros(n, dtype=np.uint32)
        status = _n.people_track(self.handle, float(time), p.ctypes.data if n else None,
                                 c.ctypes.data if c is not None and n else None, n,
                                 ids.ctypes.data if n else None, n)
        if status:
            self._raise(status, "kata_people_track")
        return ids

    def _ids_of(self, fn: Any, call: str) -> List[int]:
        count = ctypes.c_uint32()
        status = fn(self.handle, self._list.ctypes.data, self._list.size, ctypes.byref(count))
        if status:
            self._raise(status, call)
        return [int(x) for x in self._list[:count.value]]

    @property
    def opened_streams(self) -> List[int]:
        """The streams the last track() opened (new people)."""
        return self._ids_of(_n.people_opened, "kata_people_opened")

    @property
    def closed_streams(self) -> List[int]:
        """The streams the last track() closed (unseen for longer than forget_seconds)."""
        return self._ids_of(_n.people_closed, "kata_people_closed")

    @property
    def streams(self) -> List[int]:
        """The streams open now, seen or hidden."""
        return self._ids_of(_n.people_streams, "kata_people_streams")

    def predicted(self, stream_id: int, time: float) -> np.ndarray:
        """Where a stream's person is predicted at `time`: their centroid, (3,) float64."""
        out = np.zeros(3, dtype=np.float64)
        status = _n.people_predicted(self.handle, int(stream_id), float(time), out.ctypes.data)
        if status:
            self._raise(status, "kata_people_predicted")
        return out

    def counters(self) -> Dict[str, int]:
        """kata_people_get_counters as a dict (frames, poses, assigned, opened, closed, refused_* ...)."""
        c = _n.PeopleCounters()
        c.struct_size = ctypes.sizeof(c)
        status = _n.people_get_counters(self.handle, ctypes.byref(c))
        if status:
            self._raise(status, "kata_people_get_counters")
        return {name: int(getattr(c, name)) for name, _ in _n.PeopleCounters._fields_[1:]}


def people_stream_id(group: int, person: int) -> int:
    """kata_people_stream_id: the stream a runtime scores person `person` (a tracker id: 1, 2, ...)
    of group stream `group` on."""
    return int(_n.people_stream_id(int(group), int(person)))


def write_people_frame(stream_id: int, sequence: int, capture_time: float, poses: Any,
                       confidences: Optional[Any] = None) -> bytes:
    """kata_message_write_people_frame: one image of group stream `stream_id` for a runtime's
    ingest (kata serve): poses (n, joints, 3) floats in any order (n may be 0: give (0, joints, 3)),
    confidences (n, joints) or None. KataError on a refusal. [any thread]"""
    p = np.ascontiguousarray(poses, dtype=np.float32)
    if p.ndim != 3 or p.shape[2] != 3:
        raise ValueError("poses must be (n, joints, 3), got shape %s" % (p.shape,))
    m = _n.PeopleFrameMessage()
    _n.people_frame_message_init_sized(ctypes.byref(m), ctypes.sizeof(m))
    m.stream_id, m.sequence, m.capture_time = int(stream_id), int(sequence), float(capture_time)
    m.pose_count, m.joint_count = p.shape[0], p.shape[1]
    m.positions = p.ctypes.data if p.size else None
    c = None
    if confidences is not None:
        c = np.ascontiguousarray(confidences, dtype=np.float32)
        if c.size != p.shape[0] * p.shape[1]:
            raise ValueError("confidences must be (%d, %d), got shape %s" % (p.shape[0], p.shape[1], c.shape))
        m.confidences = c.ctypes.data if c.size else None
    size = ctypes.c_size_t(0)
    status = _n.message_write_people_frame(ctypes.byref(m), None, 0, ctypes.byref(size))
    if status == Status.E_BUFFER_TOO_SMALL:
        buffer = ctypes.create_string_buffer(size.value)
        status = _n.message_write_people_frame(ctypes.byref(m), buffer, size.value, ctypes.byref(size))
        if status == Status.OK:
            return buffer.raw[:size.value]
    raise KataError(status, (_n.context_last_error(None) or b"").decode(), "kata_message_write_people_frame")
