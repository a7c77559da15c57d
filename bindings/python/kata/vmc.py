"""The VMC protocol (kata/vmc.h; docs/vmc.md): a humanoid pose as one VMC bundle (OSC over UDP) for
any VMC receiver (Unity EVMC4U, Unreal VMC4UE, Blender VMC4B, Godot), and a VMC performer's
datagrams read back into the joints of the "vrm" layout.

    import socket
    with kata.Context() as ctx, ctx.load_clip(path) as clip, clip.skeleton() as sk, \\
         kata.HumanoidRig.create(ctx, sk, layout="cmu") as rig:
        udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        udp.sendto(kata.vmc_write_pose(rig.pose(clip.positions(10)), time=0.0), ("127.0.0.1", kata.VMC_PORT))

    with kata.Context() as ctx, kata.VmcReader.create(ctx) as reader:
        if reader.read(udp.recv(65536), arrival_time=time.monotonic()):
            xyz, t = reader.positions()          # (22, 3) metres, kata's right-handed frame

OSC is written and read by liblo inside libkata; the header is the manual (the bundle's messages,
the frames, what a reader counts)."""
import ctypes
from typing import Any, NamedTuple, Optional, Tuple

import numpy as np

from . import _native as _n
from ._util import _text
from .errors import KataError, Status
from .humanoid import HumanoidPose
from .objects import Context, _Handle

__all__ = ["VMC_PORT", "VMC_JOINTS", "VMC_DEFAULT_MAX_PACKET", "vmc_write_pose", "VmcReader", "VmcCounters"]

#: The default UDP port of a VMC receiver (KATA_VMC_PORT).
VMC_PORT = 39539
#: Joints of the "vrm" layout a reader's positions() gives (KATA_VMC_JOINTS), in the layout's order.
VMC_JOINTS = _n.VMC_JOINTS
#: The largest datagram a reader takes by default (KATA_VMC_DEFAULT_MAX_PACKET).
VMC_DEFAULT_MAX_PACKET = 65536


def vmc_write_pose(pose: HumanoidPose, time: float, metres_per_unit: float = 1.0) -> bytes:
    """kata_vmc_write_pose: one frame of `pose` as a VMC bundle (the bytes to send as one UDP
    datagram): its timetag the wall clock now, /VMC/Ext/Root/Pos, /VMC/Ext/Bone/Pos per placed bone
    (parents first, Unity's frame: a RIGHT_HANDED pose is mirrored), /VMC/Ext/OK 1 and /VMC/Ext/T
    `time` (seconds, the caller's clock). metres_per_unit scales positions (1 for a HumanoidRig's
    poses). KataError for a non-finite value, no Hips placed, metres_per_unit not > 0."""
    if not isinstance(pose, HumanoidPose):
        raise TypeError("pose must be a kata.HumanoidPose (HumanoidRig.pose / pose_ghost / rest_pose)")
    size = ctypes.c_size_t(0)
    buf = ctypes.create_string_buffer(4096)  # every bone placed: under 2 KiB (kata/vmc.h)
    for _ in range(2):
        status = _n.vmc_write_pose(ctypes.byref(pose._c), float(time), float(metres_per_unit), buf, len(buf),
                                   ctypes.byref(size))
        if status == Status.E_BUFFER_TOO_SMALL and size.value > len(buf):
            buf = ctypes.create_string_buffer(size.value)
            continue
        if status:
            raise KataError(status, _text(_n.context_last_error(None)) or "kata_vmc_write_pose refused the pose",
                            "kata_vmc_write_pose")
        return buf.raw[:size.value]
    raise KataError(Status.E_BUFFER_TOO_SMALL, "the bundle did not fit", "kata_vmc_write_pose")


class VmcCounters(NamedTuple):
    """What a reader counted (kata_vmc_counters): every datagram in packets, a refused one once more
    by its cause; messages skipped inside a good datagram by theirs."""
    packets: int
    frames: int
    malformed: int
    oversized: int
    wrong_type: int
    unknown_bone: int
    bad_value: int
    out_of_order: int
    ignored: int


class VmcReader(_Handle):
    """A VMC performer's datagrams into the joints of the "vrm" layout (kata_vmc_reader); one thread
    at a time. Bad input is never an error: it is counted (counters) and changes nothing."""
    _release = _n.vmc_reader_destroy

    @classmethod
    def create(cls, context: Context, max_packet_bytes: int = 0) -> "VmcReader":
        """kata_vmc_reader_create: datagrams above max_packet_bytes (0: VMC_DEFAULT_MAX_PACKET; at
        most 1 MiB) are counted as oversized."""
        return context._make(cls, "kata_vmc_reader_create", _n.vmc_reader_create, int(max_packet_bytes))

    def _raise(self, status: int, call: str) -> None:
        raise KataError(status, _text(_n.vmc_reader_last_error(self._h)) or call, call)

    def read(self, packet: Any, arrival_time: float = 0.0) -> bool:
        """kata_vmc_reader_read: one datagram (bytes, as received). True when it ended a frame (then
        read it with positions()). arrival_time: seconds on the caller's clock, the frame's time
        when the datagram carries neither /VMC/Ext/T nor a bundle timetag."""
        data = bytes(packet)
        frame = ctypes.c_int32(0)
        status = _n.vmc_reader_read(self.handle, data, len(data), float(arrival_time), ctypes.byref(frame))
        if status:
            self._raise(status, "kata_vmc_reader_read")
        return bool(frame.value)

    def positions(self) -> Optional[Tuple[np.ndarray, float]]:
        """kata_vmc_reader_positions: the newest frame's joints (VMC_JOINTS, 3) float32, metres, in
        kata's right-handed frame (+Y up, Unity's x negated), and its time (seconds); None before the
        first frame. Push them to a stream of the "vrm" layout."""
        out = np.empty((VMC_JOINTS, 3), dtype=np.float32)
        t = ctypes.c_double(0.0)
        status = _n.vmc_reader_positions(self.handle, out.ctypes.data, out.size, ctypes.byref(t))
        if status == Status.NO_DATA:
            return None
        if status:
            self._raise(status, "kata_vmc_reader_positions")
        return out, float(t.value)

    @property
    def counters(self) -> VmcCounters:
        """kata_vmc_reader_get_counters."""
        c = _n.VmcCounters()
        c.struct_size = ctypes.sizeof(c)
        status = _n.vmc_reader_get_counters(self.handle, ctypes.byref(c))
        if status:
            self._raise(status, "kata_vmc_reader_get_counters")
        return VmcCounters(*(int(getattr(c, f)) for f in VmcCounters._fields))
