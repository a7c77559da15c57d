"""Messages: a subscriber of a runtime's (or `kata serve`'s) results, decoded by the C library's
verifier (kata_message_read_result); and the messages a source sends to a runtime's ingest, written
by the C library's writers (kata_message_write_*, since 1.1)."""
import collections
import ctypes
import os
import time
from typing import Any, Callable, Deque, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from . import _native as _n
from ._util import _address, _positions_f32, _typed, _utf8
from .errors import KataError, Status

__all__ = ["Subscriber", "ResultMessage", "PracticeSection", "read_message", "write_skeleton", "write_frame",
           "write_practice", "Repetition", "read_repetition", "write_repetition", "ROM_JOINTS"]

#: The joint angles of a repetition's range of motion, in order (kata_rom_joint).
ROM_JOINTS = ("left_knee", "right_knee", "left_hip", "right_hip", "left_elbow", "right_elbow", "left_shoulder",
              "right_shoulder")


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
    cue (the phrase, "left knee: bend 30 deg more"; "" for none). Over NATS also owner (the kata
    serve shard that computed it) and epoch (its lease tenure of the stream's partition); "" and 0
    over ZeroMQ."""
    __slots__ = ("stream_id", "result_sequence", "frame_sequence", "frame_index", "capture_time", "arrival_ns",
                 "computed_ns", "published_ns", "scored", "matched_teacher_frame", "matched_teacher_time",
                 "distance", "score", "parts", "part_scores", "part_to_fix", "state", "ghost", "practice",
                 "cue_joint", "cue_degrees", "cue_action", "cue", "owner", "epoch", "repetition",
                 "repetition_progress")
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
    owner: str
    epoch: int

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
        # 1.1: the repetition in progress (1 + the complete ones; 0 without a clip teacher or from an
        # older runtime) and the progress through the teacher's section, 0..1.
        self.repetition = int(m.repetition)
        self.repetition_progress = float(m.repetition_progress)
        # Over NATS (Subscriber on nats:// URLs): the shard that computed it and its lease tenure,
        # from the result's subject; "" and 0 over ZeroMQ.
        self.owner, self.epoch = "", 0
        # The C ghost pointer is valid only until this thread's next call: copied now.
        self.ghost = (np.ctypeslib.as_array(ctypes.cast(m.ghost, ctypes.POINTER(ctypes.c_float)),
                                            shape=(m.ghost_joint_count, 3)).copy()
                      if m.ghost_joint_count and m.ghost else None)

    def __repr__(self) -> str:
        return "ResultMessage(stream=%d, seq=%d, score=%.2f)" % (self.stream_id, self.result_sequence, self.score)




def _set_cue(out: Any, rec: "_n.ResultRecord") -> None:
    """The cue fields of a Python result from its record (ResultMessage, stream.ScoreRecord)."""
    name = _n.gpd_joint_name(rec.cue_joint) if rec.cue_joint >= 0 else None
    out.cue_joint = name.decode("utf-8", "replace") if name else ""
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


class Repetition:
    """One repetition of the teacher's section (kata_repetition, 1.1; docs/coach/repetitions.md):
    index (1, 2, 3...; a partial one the index the attempt would have had), partial (abandoned
    before the end, not counted), start_time / end_time (student seconds, the stream's clock), tempo
    (duration / the teacher section's: 1.2 is 20 % slower), score (mean total), part_to_fix
    (BodyPart or -1), cue (the phrase shown most, "" for none), cue_joint ("LKnee", ""), cue_degrees,
    cue_action, range and teacher_range (dicts of the ROM_JOINTS, degrees), coverage (0..1) and
    stream_id (0 for a Stream's)."""
    __slots__ = ("stream_id", "index", "partial", "start_time", "end_time", "tempo", "score", "part_to_fix",
                 "cue_joint", "cue_degrees", "cue_action", "cue", "range", "teacher_range", "coverage")

    def __init__(self, r: "_n.Repetition") -> None:
        self.stream_id = int(r.stream_id)
        self.index = int(r.index)
        self.partial = bool(r.partial)
        self.start_time, self.end_time, self.tempo = float(r.start_time), float(r.end_time), float(r.tempo)
        self.score = float(r.score)
        self.part_to_fix = int(r.part_to_fix)
        cue = _n.ResultRecord()  # the cue's phrase through kata_cue_text
        cue.struct_size = ctypes.sizeof(cue)
        cue.part_to_fix, cue.cue_joint, cue.cue_degrees, cue.cue_action = (r.part_to_fix, r.cue_joint, r.cue_degrees,
                                                                          r.cue_action)
        _set_cue(self, cue)
        self.range = dict(zip(ROM_JOINTS, (float(v) for v in r.range)))
        self.teacher_range = dict(zip(ROM_JOINTS, (float(v) for v in r.teacher_range)))
        self.coverage = float(r.coverage)

    def __repr__(self) -> str:
        return "Repetition(%d%s, %.2f-%.2f s, tempo %.2f, score %.1f)" % (
            self.index, " partial" if self.partial else "", self.start_time, self.end_time, self.tempo, self.score)


def read_repetition(message: bytes) -> Optional[Repetition]:
    """kata_message_read_repetition: a Repetition message of a runtime (published right after the
    result of the frame that ended it). None for a valid message of another kind (a result,
    stats); KataError E_PARSE for a refused one. [any thread]"""
    r = _n.Repetition()
    r.struct_size = ctypes.sizeof(r)
    data = bytes(message)
    status = _n.message_read_repetition(data, len(data), ctypes.byref(r))
    if status == Status.NO_DATA:
        return None
    if status:
        raise KataError(status, "message of %d bytes refused" % len(data), "kata_message_read_repetition")
    return Repetition(r)


def write_repetition(stream_id: int, index: int, start_time: float, end_time: float, tempo: float, score: float,
                     partial: bool = False, part_to_fix: int = -1, cue_joint: int = -1, cue_degrees: float = 0.0,
                     cue_action: int = -1, range: Sequence[float] = (0.0,) * 8,
                     teacher_range: Sequence[float] = (0.0,) * 8, coverage: float = 1.0) -> bytes:
    """kata_message_write_repetition: the Repetition message a runtime publishes (for carrying a
    runtime's messages over another transport, and for testing subscribers)."""
    r = _n.Repetition()
    r.struct_size = ctypes.sizeof(r)
    r.stream_id, r.index, r.partial = stream_id, index, int(bool(partial))
    r.start_time, r.end_time, r.tempo, r.score = start_time, end_time, tempo, score
    r.part_to_fix, r.cue_joint, r.cue_degrees, r.cue_action = part_to_fix, cue_joint, cue_degrees, cue_action
    r.range[:] = [float(v) for v in range]
    r.teacher_range[:] = [float(v) for v in teacher_range]
    r.coverage = coverage
    buf = ctypes.create_string_buffer(1024)
    size = ctypes.c_size_t(0)
    status = _n.message_write_repetition(ctypes.byref(r), buf, len(buf), ctypes.byref(size))
    if status:
        raise KataError(status, "repetition refused", "kata_message_write_repetition")
    return buf.raw[:size.value]


class _Nats:
    """The NATS side of Subscriber: Debian's libnats (libnats3.4, the C client kata serve uses),
    called through ctypes, so no Python NATS package is needed. Results arrive on
    `<prefix>.out.<topic>.<epoch>.<owner>` (docs/deploy.md); one subscription, read synchronously."""
    # natsStatus values (nats/status.h of libnats 3.4; the enum has kept its order since 1.x).
    OK, SLOW_CONSUMER, TIMEOUT = 0, 20, 26
    _lib: Any = None

    @classmethod
    def library(cls) -> Any:
        if cls._lib is None:
            import ctypes.util
            names = [n for n in (os.environ.get("KATA_NATS_LIBRARY"), ctypes.util.find_library("nats"), "libnats.so.3.4",
                                 "libnats.so") if n]
            errors = []
            for name in names:
                try:
                    lib = ctypes.CDLL(name)
                    break
                except OSError as e:
                    errors.append(str(e))
            else:
                raise KataError(Status.E_NOT_FOUND, "a nats:// subscriber needs libnats (Debian: apt-get install "
                                "libnats3.4): " + "; ".join(errors), "Subscriber")
            vp, pp, c_int, c_char_p = ctypes.c_void_p, ctypes.POINTER(ctypes.c_void_p), ctypes.c_int, ctypes.c_char_p
            for name, res, args in (("natsOptions_Create", c_int, [pp]), ("natsOptions_Destroy", None, [vp]),
                                    ("natsOptions_SetServers", c_int, [vp, ctypes.POINTER(c_char_p), c_int]),
                                    ("natsOptions_SetUserCredentialsFromFiles", c_int, [vp, c_char_p, c_char_p]),
                                    ("natsOptions_SetMaxReconnect", c_int, [vp, c_int]),
                                    ("natsOptions_SetReconnectWait", c_int, [vp, ctypes.c_int64]),
                                    ("natsConnection_Connect", c_int, [pp, vp]),
                                    ("natsConnection_FlushTimeout", c_int, [vp, ctypes.c_int64]),
                                    ("natsConnection_Destroy", None, [vp]),
                                    ("natsConnection_SubscribeSync", c_int, [pp, vp, c_char_p]),
                                    ("natsSubscription_SetPendingLimits", c_int, [vp, c_int, c_int]),
                                    ("natsSubscription_NextMsg", c_int, [pp, vp, ctypes.c_int64]),
                                    ("natsSubscription_Destroy", None, [vp]),
                                    ("natsMsg_GetSubject", c_char_p, [vp]), ("natsMsg_GetData", vp, [vp]),
                                    ("natsMsg_GetDataLength", c_int, [vp]), ("natsMsg_Destroy", None, [vp]),
                                    ("natsConnection_GetConnectedUrl", c_int, [vp, c_char_p, ctypes.c_size_t]),
                                    ("natsStatus_GetText", c_char_p, [c_int])):
                f = getattr(lib, name)
                f.restype, f.argtypes = res, args
            cls._lib = lib
        return cls._lib

    def __init__(self, servers: Sequence[str], subject: str, credentials: Optional[str], pending: int) -> None:
        self.lib = lib = self.library()
        self.options, self.connection, self.subscription = (ctypes.c_void_p(), ctypes.c_void_p(), ctypes.c_void_p())
        try:
            self.check(lib.natsOptions_Create(ctypes.byref(self.options)), "natsOptions_Create")
            urls = (ctypes.c_char_p * len(servers))(*[u.encode() for u in servers])
            self.check(lib.natsOptions_SetServers(self.options, urls, len(servers)), "natsOptions_SetServers")
            if credentials:
                self.check(lib.natsOptions_SetUserCredentialsFromFiles(self.options, credentials.encode(), None),
                           "natsOptions_SetUserCredentialsFromFiles")
            # Reconnect for as long as it takes, as the shards do: a server restart is an outage, not an end.
            self.check(lib.natsOptions_SetMaxReconnect(self.options, -1), "natsOptions_SetMaxReconnect")
            self.check(lib.natsOptions_SetReconnectWait(self.options, 100), "natsOptions_SetReconnectWait")
            self.check(lib.natsConnection_Connect(ctypes.byref(self.connection), self.options),
                       "natsConnection_Connect to " + ", ".join(servers))
            self.check(lib.natsConnection_SubscribeSync(ctypes.byref(self.subscription), self.connection,
                                                        subject.encode()), "natsConnection_SubscribeSync")
            self.check(lib.natsSubscription_SetPendingLimits(self.subscription, pending, -1),
                       "natsSubscription_SetPendingLimits")
            # The server has the subscription before the constructor returns: nothing published
            # after it is missed.
            self.check(lib.natsConnection_FlushTimeout(self.connection, 5000), "natsConnection_FlushTimeout")
        except BaseException:
            self.close()
            raise

    def check(self, status: int, call: str) -> None:
        if status != self.OK:
            text = self.lib.natsStatus_GetText(status)
            raise KataError(Status.E_IO, "%s: %s" % (call, text.decode("utf-8", "replace") if text else status), "Subscriber")

    def next(self, timeout_ms: int) -> Tuple[int, Optional[Tuple[str, bytes]]]:
        """(status, (subject, data)) of the next message; status TIMEOUT or SLOW_CONSUMER with None."""
        msg = ctypes.c_void_p()
        status = self.lib.natsSubscription_NextMsg(ctypes.byref(msg), self.subscription, max(1, timeout_ms))
        if status != self.OK:
            if status not in (self.TIMEOUT, self.SLOW_CONSUMER):
                self.check(status, "natsSubscription_NextMsg")
            return status, None
        try:
            subject = (self.lib.natsMsg_GetSubject(msg) or b"").decode("ascii", "replace")
            data = ctypes.string_at(self.lib.natsMsg_GetData(msg), self.lib.natsMsg_GetDataLength(msg))
        finally:
            self.lib.natsMsg_Destroy(msg)
        return status, (subject, data)

    def connected_url(self) -> Optional[str]:
        """The server this connection reads from now (None while it reconnects)."""
        buf = ctypes.create_string_buffer(256)
        if self.connection.value and self.lib.natsConnection_GetConnectedUrl(self.connection, buf, len(buf)) == 0 and buf.value:
            return buf.value.decode("ascii", "replace")
        return None

    def close(self) -> None:
        lib = self.lib
        if self.subscription:
            lib.natsSubscription_Destroy(self.subscription)
            self.subscription = ctypes.c_void_p()
        if self.connection:
            lib.natsConnection_Destroy(self.connection)
            self.connection = ctypes.c_void_p()
        if self.options:
            lib.natsOptions_Destroy(self.options)
            self.options = ctypes.c_void_p()


def _parse_result_subject(prefix: str, subject: str) -> Optional[Tuple[int, int, str]]:
    """`<prefix>.out.<16 hex digits>.<epoch>.<owner>` -> (stream id, epoch, owner); None otherwise
    (sdk/src/transport/nats/results.cpp parse_result_subject)."""
    head = prefix + ".out."
    if not subject.startswith(head):
        return None
    parts = subject[len(head):].split(".", 2)
    if len(parts) != 3 or len(parts[0]) != 16 or not parts[2]:
        return None
    topic, epoch, owner = parts
    if any(c not in "0123456789abcdef" for c in topic) or not epoch.isdigit() or len(epoch) > 19:
        return None
    return int(topic, 16), int(epoch), owner


def _is_nats(endpoint: Any) -> bool:
    first = endpoint if isinstance(endpoint, str) else (endpoint[0] if endpoint else "")
    return isinstance(first, str) and first.startswith(("nats://", "tls://"))


class Subscriber:
    """The results of a runtime, `kata serve`, or kata serve shards over NATS, decoded with
    kata_message_read_result. stream: only that stream id, or all. Valid non-result messages
    (skeleton definitions, stats, practice settings) and refused messages are counted (skipped,
    refused), never returned.

    ZeroMQ (Debian's python3-zmq): endpoint is a publish endpoint ("tcp://127.0.0.1:5556"); a SUB
    socket with the stream's topic as its prefix.

        with kata.Subscriber("tcp://127.0.0.1:5556") as sub:
            msg = sub.receive(timeout=1.0)   # a ResultMessage, or None after 1 s without one

    NATS (Debian's libnats3.4, through ctypes): endpoint is a server URL, a comma-separated list of
    them ("nats://n0:4222,nats://n1:4222,nats://n2:4222", "tls://..."), or a Python list, one
    cluster; the subscriber follows the cluster when the server it is connected to is lost
    (resubscribing on another within about 0.1 s; what the servers routed meanwhile is lost,
    result_sequence gaps show it); subject_prefix is the shards' [transport]
    subject_prefix ("kata"), credentials a .creds file. Results come from whichever shard holds
    the stream's partition; each message carries its owner and epoch (ResultMessage.owner,
    .epoch), and a result from a former holder that arrives after a newer holder's is dropped
    (counted in stale; handovers counts the moves seen), as docs/deploy.md asks of every
    subscriber. Messages the client library dropped because this reader fell behind are counted
    in dropped (a result_sequence gap shows where).

    One thread at a time."""

    def __init__(self, endpoint: Any, stream: Optional[int] = None, receive_hwm: int = 100000,
                 subject_prefix: str = "kata", credentials: Optional[str] = None) -> None:
        self.skipped = 0  #: valid messages that are not results (skeleton definitions, stats, practice settings)
        self.refused = 0  #: messages the verifier refused (or, over NATS, on a subject that is not a result's)
        self.stale = 0  #: NATS: results of a former holder after a newer holder's (dropped)
        self.handovers = 0  #: NATS: a stream's results seen moving to a newer holder
        self.dropped = 0  #: NATS: times the client library dropped messages for this slow reader
        #: 1.1: the Repetition messages received with the results (docs/coach/repetitions.md), oldest
        #: first; the newest 1024 are kept: pop them as they come.
        self.repetitions: Deque[Repetition] = collections.deque(maxlen=1024)
        self._nats: Optional[_Nats] = None
        self._socket: Any = None
        if _is_nats(endpoint):
            # A URL, a comma-separated list of them ("nats://n0:4222,nats://n1:4222"), or a list.
            servers = [u.strip() for e in ([endpoint] if isinstance(endpoint, str) else list(endpoint))
                       for u in str(e).split(",") if u.strip()]
            self._prefix = subject_prefix
            self._newest: dict = {}  # stream id -> newest epoch seen (bounded below)
            subject = "%s.out.%s" % (subject_prefix, ">" if stream is None else "%016x.>" % stream)
            self._nats = _Nats(servers, subject, credentials, receive_hwm)
            return
        import zmq  # python3-zmq: only a ZeroMQ subscriber needs it
        self._zmq = zmq
        self._socket = zmq.Context.instance().socket(zmq.SUB)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.RCVHWM, receive_hwm)
        self._socket.setsockopt(zmq.SUBSCRIBE, b"" if stream is None else b"%016x" % stream)
        self._socket.connect(endpoint)
        self._poller = zmq.Poller()
        self._poller.register(self._socket, zmq.POLLIN)

    def _decode(self, data: bytes) -> Optional[ResultMessage]:
        try:
            m = read_message(data)
        except KataError:
            self.refused += 1
            return None
        if m is None:
            r = read_repetition(data)
            if r is not None:
                self.repetitions.append(r)
            else:
                self.skipped += 1
        return m

    def _accept_epoch(self, stream_id: int, epoch: int) -> bool:
        newest = self._newest.get(stream_id)
        if newest is None:
            if len(self._newest) < 65536:  # bounded, as the C++ EpochFilter: beyond it, not remembered
                self._newest[stream_id] = epoch
            return True
        if epoch < newest:
            self.stale += 1
            return False
        if epoch > newest:
            self.handovers += 1
            self._newest[stream_id] = epoch
        return True

    @property
    def nats_server(self) -> Optional[str]:
        """NATS: the URL of the server this subscriber reads from now (None while it reconnects, or
        over ZeroMQ)."""
        return self._nats.connected_url() if self._nats is not None else None

    def receive(self, timeout: Optional[float] = None) -> Optional[ResultMessage]:
        """The next result message; None when none arrives within timeout seconds (None: wait)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            wait = None if deadline is None else max(0.0, deadline - time.monotonic())
            if self._nats is not None:
                status, got = self._nats.next(1000 if wait is None else int(wait * 1000))
                if got is None:
                    self.dropped += status == _Nats.SLOW_CONSUMER
                    if status == _Nats.TIMEOUT and deadline is not None and time.monotonic() >= deadline:
                        return None
                    continue
                subject, data = got
                where = _parse_result_subject(self._prefix, subject)
                if where is None:
                    self.refused += 1
                    continue
                m = self._decode(data)
                if m is None:
                    continue
                if m.stream_id != where[0]:  # the subject and the message disagree: not a shard's
                    self.refused += 1
                    continue
                if not self._accept_epoch(where[0], where[1]):
                    continue
                m.epoch, m.owner = where[1], where[2]
                return m
            if not self._poller.poll(None if wait is None else int(wait * 1000)):
                return None
            m = self._decode(self._socket.recv())
            if m is not None:
                return m

    def close(self) -> None:
        if self._nats is not None:
            self._nats.close()
            self._nats = None
        if self._socket is not None:
            self._socket.close(0)
            self._socket = None

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
    raise KataError(status, (_n.context_last_error(None) or b"").decode("utf-8", "replace"), call)


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
                confidences: Any = None, presences: Any = None) -> bytes:
    """kata_message_write_frame: one frame message. positions: (joints, 3) floats in the skeleton
    definition's joint order and units, all finite; confidences: joints floats in [0, 1] (NaN:
    missing), or None; presences: MediaPipe's second landmark channel, joints floats in [0, 1], or
    None (the stream reads each joint's confidence as the smaller of the two); capture_time: seconds
    on the source's clock. KataError on a refusal (E_NON_FINITE for a NaN or infinite coordinate).
    [any thread]"""
    m, _kept = _frame_message(stream_id, sequence, capture_time, positions, confidences, presences)
    return _write(_n.message_write_frame, m, "kata_message_write_frame")


def _frame_message(stream_id: int, sequence: int, capture_time: float, positions: Any, confidences: Any,
                   presences: Any) -> Tuple[Any, list]:
    """A filled kata_frame_message and the arrays it points into (kept alive until the write)."""
    p = _positions_f32(positions)
    if p.size % 3:
        raise ValueError("positions hold joints x 3 floats, not %d floats" % p.size)
    m = _n.FrameMessage()
    _n.frame_message_init_sized(ctypes.byref(m), ctypes.sizeof(m))
    m.stream_id, m.sequence, m.capture_time = stream_id, sequence, capture_time
    m.joint_count = p.size // 3
    m.positions = _address(p) if p.size else None
    c = _per_joint(confidences, m.joint_count, "confidences")
    m.confidences = None if c is None else _address(c)
    q = _per_joint(presences, m.joint_count, "presences")
    m.presences = None if q is None else _address(q)
    return m, [p, c, q]


@_typed
def write_frame_batch(frames: Sequence[Any]) -> bytes:
    """kata_message_write_frame_batch (since 1.1): the frames of many streams of one source in one
    message (a mocap stage's tick), for a runtime's ingest. frames: a sequence of tuples
    (stream_id, sequence, capture_time, positions[, confidences[, presences]]), each as write_frame
    takes them; 1 to 4096 of them. The runtime judges each frame alone (a refused one is counted by
    cause, the others go on). KataError on a refusal (the message names the frame's index).
    [any thread]"""
    if len(frames) == 0:
        raise ValueError("a frame batch holds at least one frame")
    messages, keep = [], []
    for f in frames:
        if not 4 <= len(f) <= 6:
            raise ValueError("a batch's frame is (stream_id, sequence, capture_time, positions[, confidences"
                             "[, presences]]), not %d values" % len(f))
        m, k = _frame_message(*(tuple(f) + (None,) * (6 - len(f))))
        messages.append(m)
        keep.append(k)
    pointers = (ctypes.POINTER(_n.FrameMessage) * len(messages))(*[ctypes.pointer(m) for m in messages])
    size = ctypes.c_size_t(0)
    status = _n.message_write_frame_batch(pointers, len(messages), None, 0, ctypes.byref(size))
    if status == Status.E_BUFFER_TOO_SMALL:
        buffer = ctypes.create_string_buffer(size.value)
        status = _n.message_write_frame_batch(pointers, len(messages), buffer, size.value, ctypes.byref(size))
        if status == Status.OK:
            return buffer.raw[:size.value]
    raise KataError(status, (_n.context_last_error(None) or b"").decode("utf-8", "replace"), "kata_message_write_frame_batch")


def _per_joint(values: Any, joints: int, what: str) -> Optional[np.ndarray]:
    """One float32 a joint (a frame's confidences or presences), or None when not given."""
    if values is None:
        return None
    v = np.ascontiguousarray(values, dtype=np.float32)
    if v.size != joints:
        raise ValueError("%s hold one float per joint (%d), not %d" % (what, joints, v.size))
    return v


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
