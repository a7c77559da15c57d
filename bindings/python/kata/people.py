"""Several people in one picture (kata_people, kata/people.h): which stream each unlabeled pose
of a multi-person detector belongs to.

    with kata.Context() as ctx, kata.People(ctx, joint_count=33, max_people=4) as people:
        ids = people.track(t, poses, confidences)   # poses (n, 33, 3), any order -> ids (n,)
        people.opened, people.closed               # streams this frame opened and closed

An id is a person's stream (0: the pose was refused, see counters()); ids count up from 1 and are
not reused. kata/people.h explains the cost, the gate and what identity rests on.
"""
import ctypes
from typing import Any, Dict, List, NoReturn, Optional

import numpy as np

from . import _native as _n
from ._util import _text
from .errors import KataError
from .objects import Context, _Handle

__all__ = ["People"]

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
    def opened(self) -> List[int]:
        """The streams the last track() opened (new people)."""
        return self._ids_of(_n.people_opened, "kata_people_opened")

    @property
    def closed(self) -> List[int]:
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
