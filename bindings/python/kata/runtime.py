"""The runtime (kata_runtime): many streams on worker threads, frames in and results out on ZeroMQ."""
import ctypes
from typing import Any, Optional, Tuple

import numpy as np

from . import _native as _n
from ._util import _address, _positions_f32, _text, _type_error, _typed, _utf8
from .errors import KataError, Status
from .objects import _Handle
from .stream import Stream

__all__ = ["Runtime", "shard_of"]


def _stream_open_hook(callback: Any) -> Any:
    """A kata_stream_open_callback calling callback(info, stream) (Context.create_runtime)."""
    def _hook(user: Optional[int], info: Any, handle: Optional[int]) -> int:
        i = info.contents
        stream = Stream(handle, None)
        stream._joints = int(i.joint_count)
        try:
            accepted = callback({"stream_id": int(i.stream_id), "revision": int(i.revision),
                                 "joint_count": int(i.joint_count), "layout": _text(i.layout) or "",
                                 "has_rest_pose": bool(i.has_rest_pose), "frame_rate": float(i.frame_rate)},
                                stream)
        except Exception as e:  # refused: an exception cannot cross the C call
            import sys
            print("kata: on_stream_open raised %r; stream %d refused" % (e, int(i.stream_id)), file=sys.stderr)
            accepted = False
        finally:
            stream._h = None  # the runtime's: never released here
        return 0 if accepted is None or accepted else int(Status.E_STATE)
    return _n.StreamOpenCallback(_hook)


class Runtime(_Handle):
    """Many streams, ZeroMQ in and out (kata_runtime). push may be called from any thread (one
    producer per stream keeps its order); it never blocks: a full worker queue drops and counts."""
    _release = _n.runtime_destroy
    _stream_open_hook: Any = None  # the on_stream_open trampoline, kept alive with the runtime

    def _context_error(self) -> Optional[str]:
        return _text(_n.context_last_error(self._context.handle if self._context is not None else None))

    @_typed
    def add_stream(self, stream_id: int, stream: "Stream", layout: Optional[str] = None,
                   publish_features: bool = False) -> None:
        """kata_runtime_add_stream: hands `stream` to the runtime under stream_id; the runtime owns
        it afterwards (the Stream object is closed here without freeing it). The published
        skeleton definition names the layout the stream was opened with (a built-in layout or its
        name map); layout: None, or that same layout's name (another is refused). [any thread]"""
        h = ctypes.c_void_p(stream.handle)
        status = _n.runtime_add_stream(self.handle, stream_id, ctypes.byref(h), _utf8(layout),
                                       1 if publish_features else 0)
        if status:
            raise KataError(status, self._context_error(), "kata_runtime_add_stream")
        stream._h = None  # owned by the runtime now
        if stream._context is not None:
            stream._context._children.discard(stream)
        self._joints = getattr(self, "_joints", {})
        self._joints[stream_id] = stream._joints

    def push(self, stream_id: int, sequence: int, capture_time: float, positions: Any,
             confidences: Any = None) -> None:
        """kata_runtime_push: queues one frame (capture_time seconds, increasing; positions
        (joints, 3) float32); with confidences (joints floats, e.g. MediaPipe's visibility)
        kata_runtime_push_confidence. KataError E_NOT_FOUND (no such stream), E_QUEUE_FULL (dropped
        and counted), E_STOPPED (stop has begun). Never blocks, never allocates in C. [any thread]"""
        a = positions
        if type(a) is not np.ndarray or a.dtype != np.float32 or not a.flags.c_contiguous:
            a = _positions_f32(a)
        try:
            if confidences is None:
                status = _n.runtime_push(self.handle, stream_id, sequence, capture_time, _address(a), a.size // 3)
            else:
                c = np.ascontiguousarray(confidences, dtype=np.float32)
                if c.size != a.size // 3:
                    raise ValueError("confidences holds %d values for %d joints" % (c.size, a.size // 3))
                status = _n.runtime_push_confidence(self.handle, stream_id, sequence, capture_time, _address(a),
                                                    _address(c), a.size // 3)
        except ctypes.ArgumentError as e:
            raise _type_error(Runtime.push, (self, stream_id, sequence, capture_time, positions), {}, e) from None
        if status:
            raise KataError(status, "stream %d frame %d" % (stream_id, sequence), "kata_runtime_push")

    @_typed
    def set_practice(self, stream_id: int, revision: int, teacher_start: float = 0.0,
                     loop: Optional[Tuple[float, float]] = None) -> None:
        """kata_runtime_set_practice: from the frames pushed after it, the stream follows its clip
        teacher from teacher_start seconds, or loops the section loop = (start, end) seconds
        (teacher seconds from its first frame, as ResultMessage.matched_teacher_time); every result
        then carries practice.revision == revision. KataError E_NOT_FOUND (no such stream),
        E_INVALID_ARGUMENT (not finite, negative, outside the clip, an empty loop), E_NO_CLIP_TEACHER,
        E_QUEUE_FULL (the worker queue full, or stop has begun). Never blocks. [any thread]"""
        a, b = loop if loop is not None else (0.0, 0.0)
        status = _n.runtime_set_practice(self.handle, stream_id, revision, teacher_start, 1 if loop is not None else 0,
                                         a, b)
        if status:
            raise KataError(status, self._context_error(), "kata_runtime_set_practice")

    def offer(self, message: bytes) -> None:
        """kata_runtime_offer (1.1): hands one ingest message (bytes as write_skeleton / write_frame
        / write_frame_batch / write_practice return) to a runtime created with direct_ingest=True,
        the app's own transport in place of a ZeroMQ socket; judged there as a socket's message is
        (a malformed one is counted in counters(), not raised here). KataError E_QUEUE_FULL (not
        taken: the ring is full, the message too large, or stop has begun), E_STATE (no direct
        ingest). One thread at a time. Never blocks."""
        if not isinstance(message, (bytes, bytearray, memoryview)):
            raise TypeError("Runtime.offer takes bytes, not %s" % type(message).__name__)
        data = bytes(message)
        status = _n.runtime_offer(self.handle, data, len(data))
        if status:
            raise KataError(status, "%d-byte message" % len(data), "kata_runtime_offer")

    @_typed
    def latency_percentile(self, q: float) -> float:
        """kata_runtime_latency_percentile (1.1): nanoseconds from a frame's arrival to its result's
        hand-over to ZeroMQ (a result's arrival_ns to published_ns) below which a fraction q (0..1)
        of every result published so far lies, from the runtime's histogram (buckets 9 % wide: the
        upper edge of the bucket). 0 before the first published result, without a publisher, or
        for q outside 0..1. [any thread]"""
        return float(_n.runtime_latency_percentile(self.handle, q))

    def stop(self) -> None:
        """kata_runtime_stop: finishes every queued frame, publishes every result, stops the threads."""
        status = _n.runtime_stop(self.handle)
        if status:
            raise KataError(status, "stop failed", "kata_runtime_stop")

    def counters(self) -> dict:
        """kata_runtime_get_counters as a dict (streams, frames_in, queue_full, refused, results,
        results_dropped, published, ingest_*, people_*: the people frames, kata/runtime.h). [any thread]"""
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


@_typed
def shard_of(stream_id: int, shard_count: int) -> int:
    """kata_shard_of: the shard (0..shard_count-1) that scores stream_id (FNV-1a; stable)."""
    return int(_n.shard_of(stream_id, shard_count))
